//! Small dense linear algebra: Jacobi-scaled Cholesky inverse and log det of symmetric
//! positive-definite matrices, b × b determinants and inverses, eigenvalue helpers.

use nalgebra::DMatrix;

use crate::identify::observability::RANK_TOLERANCE;

/// A Jacobi-scaled symmetric matrix whose inverse has a larger Frobenius norm than this is
/// treated as numerically singular.
const MAX_SCALED_INVERSE: f64 = 1.0 / (RANK_TOLERANCE * RANK_TOLERANCE);

/// Inverse of a symmetric positive-definite matrix through a Jacobi-scaled Cholesky
/// factorisation (scale-equivariant); `None` if it is not numerically positive definite.
pub(super) fn spd_inverse(m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = m.nrows();
    let diagonal = m.diagonal();
    if diagonal.iter().any(|&v| v <= 0.0 || !v.is_finite()) {
        return None;
    }
    let s = diagonal.map(|v| 1.0 / v.sqrt());
    let scaled = DMatrix::from_fn(n, n, |i, j| m[(i, j)] * s[i] * s[j]);
    let inverse = scaled.cholesky()?.inverse();
    let norm = inverse.norm();
    if norm.is_nan() || norm > MAX_SCALED_INVERSE {
        return None;
    }
    Some(DMatrix::from_fn(n, n, |i, j| {
        0.5 * (inverse[(i, j)] + inverse[(j, i)]) * s[i] * s[j]
    }))
}

/// ln det of a symmetric positive-definite matrix (Jacobi-scaled Cholesky), −∞ if it is not.
pub(super) fn log_det_spd(m: &DMatrix<f64>) -> f64 {
    let n = m.nrows();
    let diagonal = m.diagonal();
    if n == 0 || diagonal.iter().any(|&v| v <= 0.0 || !v.is_finite()) {
        return f64::NEG_INFINITY;
    }
    let s = diagonal.map(|v| 1.0 / v.sqrt());
    let scaled = DMatrix::from_fn(n, n, |i, j| m[(i, j)] * s[i] * s[j]);
    match scaled.cholesky() {
        Some(chol) => {
            let l = chol.l_dirty();
            (0..n)
                .map(|i| 2.0 * l[(i, i)].ln() + diagonal[i].ln())
                .sum()
        }
        None => f64::NEG_INFINITY,
    }
}

/// ln det of a small matrix with a positive determinant, −∞ otherwise (NaN included).
pub(super) fn ln_det_small(g: &DMatrix<f64>) -> f64 {
    let b = g.nrows();
    let mut buffer: Vec<f64> = (0..b * b).map(|k| g[(k / b, k % b)]).collect();
    // ln 0 = −∞, and `max` takes 0 for a negative or NaN determinant.
    det_in_place(&mut buffer, b).max(0.0).ln()
}

/// Row (at or below `col`) of the largest entry in column `col` of the row-major b × b matrix
/// `a`, or `None` if that column is zero (or NaN) from `col` down: partial pivoting.
fn pivot_row(a: &[f64], b: usize, col: usize) -> Option<usize> {
    let (mut row, mut largest) = (col, 0.0);
    for r in col..b {
        let v = a[r * b + col].abs();
        if v > largest {
            largest = v;
            row = r;
        }
    }
    (largest > 0.0).then_some(row)
}

/// Swaps rows `r` and `s` of the row-major b × b matrix `a`.
fn swap_rows(a: &mut [f64], b: usize, r: usize, s: usize) {
    for c in 0..b {
        a.swap(r * b + c, s * b + c);
    }
}

/// Determinant of the row-major b × b matrix in `a` (overwritten), by Gaussian elimination
/// with partial pivoting.
pub(super) fn det_in_place(a: &mut [f64], b: usize) -> f64 {
    let mut det = 1.0;
    for col in 0..b {
        let Some(pivot_row) = pivot_row(a, b, col) else {
            return 0.0;
        };
        if pivot_row != col {
            swap_rows(a, b, col, pivot_row);
            det = -det;
        }
        let pivot = a[col * b + col];
        det *= pivot;
        for r in col + 1..b {
            let factor = a[r * b + col] / pivot;
            // From the pivot's column on (that column's entry below the pivot, left at about
            // zero, is not read again).
            for c in col..b {
                a[r * b + c] -= factor * a[col * b + c];
            }
        }
    }
    det
}

/// Inverse of the row-major b × b matrix `a` (overwritten) into `out`, by Gauss–Jordan
/// elimination with partial pivoting; returns the determinant (0 if singular, `out` then
/// undefined).
pub(super) fn invert_in_place(a: &mut [f64], b: usize, out: &mut [f64]) -> f64 {
    out.fill(0.0);
    for r in 0..b {
        out[r * b + r] = 1.0;
    }
    let mut det = 1.0;
    for col in 0..b {
        let Some(pivot_row) = pivot_row(a, b, col) else {
            return 0.0;
        };
        if pivot_row != col {
            swap_rows(a, b, col, pivot_row);
            swap_rows(out, b, col, pivot_row);
            det = -det;
        }
        let pivot = a[col * b + col];
        det *= pivot;
        for c in 0..b {
            a[col * b + c] /= pivot;
            out[col * b + c] /= pivot;
        }
        for r in (0..b).filter(|&r| r != col) {
            let factor = a[r * b + col];
            for c in 0..b {
                a[r * b + c] -= factor * a[col * b + c];
                out[r * b + c] -= factor * out[col * b + c];
            }
        }
    }
    det
}

/// ½ ln λ (= ln s for λ = s²), −∞ for λ ≤ 0 or NaN.
pub(super) fn half_ln(lambda: f64) -> f64 {
    0.5 * lambda.max(0.0).ln()
}

/// Smallest eigenvalue of a symmetric matrix.
pub(super) fn min_eigenvalue(m: DMatrix<f64>) -> f64 {
    m.symmetric_eigenvalues()
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
}
