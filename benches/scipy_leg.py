#!/usr/bin/env python3
"""Times scipy's least_squares(method='lm') on one 5R leg and legwise's `identify_leg/5r/lm`
criterion bench on the same 18 poses, in one run, and prints their medians and ratio.

The poses are the ones the bench identifies: the 5R model's default simulation (random poses,
the model's seed) written by `legwise simulate --poses random`, leg1's rows. The scipy side
builds its own closed-form model of the leg: with the base joint A = (Ax, Ay), the driving link
l and the driven link L, the actuated angle that puts the tip on the measured point P is
theta = atan2(P - A) + acos((l^2 + |P - A|^2 - L^2) / (2 l |P - A|)) (the model's elbow-out
working mode), and the reading is (theta - gamma) / k. Parameters: [l, L, Ax, Ay, k, gamma],
started, like legwise, from the nominal values.

Usage (from the repository root; CARGO_TARGET_DIR is honoured):
    python3 benches/scipy_leg.py              # simulate, time scipy, run the bench, compare
    python3 benches/scipy_leg.py --no-cargo   # time scipy only (on an existing CSV: --csv F)
"""
import argparse
import csv
import glob
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.optimize import least_squares

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Nominal [l1, L1, A1x, A1y, k1, gamma1] of models/5r.urdf and models/5r.yaml.
NOMINAL = np.array([0.75, 1.10, -0.5, 0.0, 1.0, 0.0])
BENCH_ID = "identify_leg/5r/lm"
# The floor of the same fit (benches/reference/closed_form_leg.rs): the leg by hand in closed
# form, solved by legwise's `solve` and by a fixed-size Levenberg-Marquardt.
FLOOR_IDS = ["identify_leg/5r/floor_solver", "identify_leg/5r/floor_fixed"]


def simulate(path):
    """Writes the 5R model's default random-pose simulation to `path` with the legwise CLI."""
    subprocess.run(
        ["cargo", "run", "--release", "--quiet", "--", "simulate", "--model",
         "models/5r.yaml", "--poses", "random", "--out", path],
        cwd=ROOT, check=True)


def leg_rows(path, leg="leg1", joint="A1"):
    """The (x, y, reading) of `leg`'s rows of a measurement CSV (the reading is in the column
    of the leg's actuated joint)."""
    with open(path, newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["leg"] == leg]
    x = np.array([float(r["x"]) for r in rows])
    y = np.array([float(r["y"]) for r in rows])
    psi = np.array([float(r[joint]) for r in rows])
    return x, y, psi


def residuals(phi, x, y, psi):
    """Predicted minus measured reading, closed form."""
    l, big_l, ax, ay, k, gamma = phi
    dx, dy = x - ax, y - ay
    r = np.hypot(dx, dy)
    cos_beta = (l * l + r * r - big_l * big_l) / (2.0 * l * r)
    theta = np.arctan2(dy, dx) + np.arccos(np.clip(cos_beta, -1.0, 1.0))
    return (theta - gamma) / k - psi


def time_scipy(x, y, psi, repeats, **options):
    """Median seconds of one least_squares solve from the nominal values, and the solution."""
    solve = lambda: least_squares(residuals, NOMINAL, method="lm", args=(x, y, psi), **options)
    result = solve()
    per_call = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(20):
            solve()
        per_call.append((time.perf_counter() - start) / 20)
    return statistics.median(per_call), result


def criterion_median(target_dir, bench_id=BENCH_ID):
    """Median of the last run of `bench_id` (in the group identify_leg/5r), seconds, from
    criterion's estimates."""
    pattern = os.path.join(target_dir, "criterion", "identify_leg_5r", bench_id.split("/")[-1],
                           "new", "estimates.json")
    found = glob.glob(pattern)
    if not found:
        sys.exit(f"no criterion estimates at {pattern}")
    with open(found[0]) as handle:
        return json.load(handle)["median"]["point_estimate"] * 1e-9


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", help="measurement CSV (default: simulate it)")
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--no-cargo", action="store_true", help="do not run the criterion bench")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        path = args.csv or os.path.join(scratch, "5r.csv")
        if not args.csv:
            simulate(path)
        x, y, psi = leg_rows(path)
    print(f"{len(x)} poses of leg1; scipy {__import__('scipy').__version__}, "
          f"numpy {np.__version__}, python {sys.version.split()[0]}")
    default, fit = time_scipy(x, y, psi, args.repeats)
    tight, tight_fit = time_scipy(x, y, psi, args.repeats, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    for name, seconds, result in [("scipy lm, default tolerances", default, fit),
                                  ("scipy lm, tolerances 1e-12", tight, tight_fit)]:
        print(f"{name:34s} median {seconds * 1e6:9.1f} us  ({result.nfev} evaluations, "
              f"cost {result.cost:.6e}, l1 = {result.x[0]:.9f})")
    if args.no_cargo:
        return
    target_dir = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    pattern = "^identify_leg/5r/(lm|floor_solver|floor_fixed)$"
    subprocess.run(["cargo", "bench", "--bench", "identify", "--", pattern],
                   cwd=ROOT, check=True)
    legwise = criterion_median(target_dir)
    print(f"{'legwise ' + BENCH_ID:34s} median {legwise * 1e6:9.1f} us")
    print(f"ratio scipy (default) / legwise: {default / legwise:7.1f}x")
    print(f"ratio scipy (1e-12)   / legwise: {tight / legwise:7.1f}x")
    for floor_id in FLOOR_IDS:
        floor = criterion_median(target_dir, floor_id)
        print(f"{floor_id:34s} median {floor * 1e6:9.1f} us: scipy (default) / it "
              f"{default / floor:6.1f}x, legwise / it {legwise / floor:5.2f}x")


if __name__ == "__main__":
    main()
