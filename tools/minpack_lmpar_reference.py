#!/usr/bin/env python3
"""Reference values for `src/solver/levenberg_marquardt/lmpar/minpack_reference.rs`.

Calls MINPACK's `lmpar` (the C translation in cminpack, Debian package `libcminpack1`) on
hand-built `R`, permutation, scaling, `Q^T r`, trust radius and starting lambda, and prints the
test's cases as Rust literals. Usage:

    apt-get download libcminpack1 && dpkg -x libcminpack1_*.deb cminpack
    python3 tools/minpack_lmpar_reference.py cminpack/usr/lib/x86_64-linux-gnu/libcminpack.so.1
"""
import ctypes
import sys

import numpy as np

D = ctypes.POINTER(ctypes.c_double)
I = ctypes.POINTER(ctypes.c_int)


def lmpar(lib, r, perm, diag, qtb, delta, par):
    """MINPACK lmpar: returns (par, x). `perm` is 0-based; cminpack's ipvt is 1-based."""
    n = len(qtb)
    r = np.asfortranarray(np.array(r, dtype=float))
    ipvt = np.array([p + 1 for p in perm], dtype=np.int32)
    diag = np.array(diag, float)
    qtb = np.array(qtb, float)
    par = ctypes.c_double(par)
    x, sdiag, wa1, wa2 = (np.zeros(n) for _ in range(4))
    c = lambda a: a.ctypes.data_as(D)
    lib.lmpar(n, c(r), n, ipvt.ctypes.data_as(I), c(diag), c(qtb), delta, ctypes.byref(par),
              c(x), c(sdiag), c(wa1), c(wa2))
    return par.value, x


R3 = [[3, 1, 0.5], [0, 2, 0.3], [0, 0, 0.7]]
RANK2 = [[2, 1, 0.3], [0, 1, 0.2], [0, 0, 0]]
TINY = [[1e-200, 0], [0, 1e-200]]
TINIER = [[1e-100, 0, 0], [0, 3e-100, 0], [0, 0, 0]]
# (what, R, perm, D, Q^T r, delta, starting lambda)
CASES = [
    ("full rank, λ iterated from 0", R3, [2, 0, 1], [1, 2, 0.5], [1, -2, 0.5], 0.1, 0.0),
    ("full rank, λ iterated from the last one", R3, [2, 0, 1], [1, 2, 0.5], [1, -2, 0.5], 0.1, 5.0),
    ("full rank, the Gauss–Newton step fits", R3, [2, 0, 1], [1, 2, 0.5], [1, -2, 0.5], 100.0, 5.0),
    ("Gauss–Newton step exactly 10 % longer than the region", [[1, 0], [0, 1]], [0, 1], [1, 1],
     [11, 0], 10.0, 0.0),
] + [
    ("rank 2 of 3, Δ=%g" % d, RANK2, [1, 2, 0], [1, 0.5, 2], [1, 1, 1], d, 0.0)
    for d in [0.05, 0.2, 0.5, 1.0, 2.0]
] + [
    ("zero gradient, Gauss–Newton step outside the region", TINY, [0, 1], [1, 1],
     [1e-200, 1e-200], 0.1, 0.0),
    # R is singular and ‖D⁻¹Jᵀr‖ underflows to 0: λ restarts from 1e-3 × MIN_POSITIVE / Δ ≈ 2e-161.
    ("zero gradient, restart above the smallest normal number", TINIER, [0, 1, 2],
     [6.7e-20, 2e-19, 1], [1e-230, 2e-230, 1], 1e-150, 0.0),
    # The minimum-norm least-squares step [0.5, 0.5] is shorter than 0.9 Δ, the truncated
    # Gauss–Newton step [1, 0] longer than 1.1 Δ: λ falls towards 0 until ‖D p‖ stops growing.
    ("rank 1 of 2, the region unreachable", [[1, 1], [0, 0]], [0, 1], [1, 1], [1, 0], 0.85, 0.0),
    ("rank 1 of 2, the region unreachable, pivoted and scaled", [[2, 1], [0, 0]], [1, 0],
     [0.5, 2], [1, 0], 0.7, 0.0),
]


def literal(v):
    v = float(v)
    return "%.1f" % v if v == int(v) and abs(v) < 1e15 else repr(v)


def main():
    lib = ctypes.CDLL(sys.argv[1])
    lib.lmpar.argtypes = [ctypes.c_int, D, ctypes.c_int, I, D, D, ctypes.c_double, D, D, D, D, D]
    for what, r, perm, diag, qtb, delta, par in CASES:
        lam, x = lmpar(lib, r, perm, diag, qtb, delta, par)
        row = lambda a: "&[" + ", ".join(literal(v) for v in a) + "]"
        print(f"""    MinpackCase {{
        what: "{what}",
        r: {row(np.array(r, float).flatten())},
        perm: &{perm},
        diag: {row(diag)},
        qtr: {row(qtb)},
        delta: {literal(delta)},
        lambda0: {literal(par)},
        lambda: {literal(lam)},
        step: {row(x)},
    }},""")


if __name__ == "__main__":
    main()
