//! The least-squares step `C⁺r` of a well-conditioned tall Jacobian by Householder QR: `n`
//! reflections of the `m × n` matrix and one triangular solve, instead of an SVD's
//! bidiagonalisation, its iterations and its `m × n` factor `U`. The same step to round-off
//! where `C` has full rank; a nearly rank-deficient `C` (or fewer rows than columns) gets
//! `None`, and the caller keeps its SVD, which decides what counts as a zero singular value.

use nalgebra::{DMatrix, DVector};

/// Smallest `|R_kk| / max |R_jj|` of the triangular factor taken by the QR step. Above it the
/// QR step and the SVD's agree to round-off times the conditioning; below it (a Jacobian
/// near rank deficiency, or columns of very different scales) the SVD keeps deciding, with
/// its own threshold for a zero singular value.
const WELL_CONDITIONED: f64 = 1e-4;

/// The least-squares solution `s` of `C s ≈ r` (`C`: `jacobian`, consumed), or `None` when
/// `C` has fewer rows than columns, its triangular factor is below [`WELL_CONDITIONED`], or
/// the step is not finite.
pub fn qr_step(jacobian: DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let n = jacobian.ncols();
    if jacobian.nrows() < n || n == 0 || !jacobian.iter().all(|v| v.is_finite()) {
        return None;
    }
    let qr = jacobian.qr();
    let triangle = qr.r();
    let diagonal = triangle.diagonal().abs();
    let largest = diagonal.max();
    // A zero matrix too (its entries are finite: no NaN here).
    if diagonal.min() <= WELL_CONDITIONED * largest {
        return None;
    }
    let mut rotated = r.clone();
    qr.q_tr_mul(&mut rotated);
    let top = rotated.rows(0, n).into_owned();
    let step = triangle.solve_upper_triangular(&top)?;
    step.iter().all(|v| v.is_finite()).then_some(step)
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::qr_step;

    /// On a non-orthogonal tall matrix with an inconsistent right-hand side the QR step is
    /// the SVD's least-squares solution to round-off; a rank-deficient matrix and a wide one
    /// are left to the SVD.
    #[test]
    fn the_qr_step_is_the_svd_least_squares_solution() {
        let c = DMatrix::from_row_slice(
            4,
            3,
            &[20.0, 1.0, 0.0, 0.0, 0.5, 0.3, 1.0, 0.0, 0.01, 2.0, 2.0, 2.0],
        );
        let r = DVector::from_vec(vec![1.0, -2.0, 0.5, 3.0]);
        let svd = c.clone().svd(true, true).solve(&r, f64::EPSILON).unwrap();
        let qr = qr_step(c.clone(), &r).expect("full rank");
        assert!((&qr - &svd).amax() <= 1e-13 * svd.amax(), "{qr} vs {svd}");
        // The normal equations hold: Cᵀ(C s − r) = 0.
        let gradient = c.tr_mul(&(&c * &qr - &r));
        assert!(gradient.amax() < 1e-12, "{gradient}");
        let mut deficient = c.clone();
        deficient.set_column(2, &(c.column(0) + c.column(1)));
        assert!(qr_step(deficient, &r).is_none());
        assert!(qr_step(c.transpose(), &DVector::zeros(3)).is_none());
    }
}
