//! The least-squares step `C⁺r` of a well-conditioned tall Jacobian by Householder QR: `n`
//! reflections of the `m × n` matrix and one triangular solve, instead of an SVD's
//! bidiagonalisation, its iterations and its `m × n` factor `U`. The same step to round-off
//! where `C` has full rank; a nearly rank-deficient `C` (or fewer rows than columns) gets
//! `None`, and the caller keeps its SVD, which decides what counts as a zero singular value.

use nalgebra::{DMatrix, DVector};

use super::column_dot::dot;

/// Smallest `|R_kk| / max |R_jj|` of the triangular factor taken by the QR step. Above it the
/// QR step and the SVD's agree to round-off times the conditioning; below it (a Jacobian
/// near rank deficiency, or columns of very different scales) the SVD keeps deciding, with
/// its own threshold for a zero singular value.
const WELL_CONDITIONED: f64 = 1e-4;

/// The least-squares solution `s` of `C s ≈ r` (`C`: `jacobian`, consumed), or `None` when
/// `C` has fewer rows than columns, its triangular factor is below [`WELL_CONDITIONED`], or
/// the step is not finite.
///
/// nalgebra's `QR` (its reflections, `r()`, `q_tr_mul` and `solve_upper_triangular`)
/// computed on the matrix's columns as slices, in the same operations and order: the same
/// bits, without building a view, a reflection or the triangular copy per column.
pub fn qr_step(jacobian: DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let (m, n) = jacobian.shape();
    if m < n || n == 0 || !jacobian.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut factored = jacobian;
    // Column-major: column j is `data[j·m..(j + 1)·m]`; column i's rows i.. become its unit
    // reflection axis, the entries above the diagonal R's.
    let data = factored.as_mut_slice();
    let mut signed_diagonal = Vec::with_capacity(n);
    for i in 0..n {
        let (left, right) = data.split_at_mut((i + 1) * m);
        let axis = &mut left[i * m + i..];
        let (value, reflects) = reflection_axis(axis);
        signed_diagonal.push(value);
        if reflects {
            for column in right.chunks_exact_mut(m) {
                reflect(axis, &mut column[i..], value.signum());
            }
        }
    }
    let diagonal = DVector::from_iterator(n, signed_diagonal.iter().map(|d| d.abs()));
    let largest = diagonal.max();
    // A zero matrix too (its entries are finite: no NaN here).
    if diagonal.min() <= WELL_CONDITIONED * largest {
        return None;
    }
    // Qᵀr.
    let mut rotated = r.clone();
    let rotated_rows = rotated.as_mut_slice();
    for (i, value) in signed_diagonal.iter().enumerate() {
        reflect(
            &data[i * m + i..(i + 1) * m],
            &mut rotated_rows[i..],
            value.signum(),
        );
    }
    // R s = (Qᵀr)₀..ₙ, R's diagonal the moduli.
    let mut step = DVector::from_column_slice(&rotated_rows[..n]);
    let step_rows = step.as_mut_slice();
    for i in (0..n).rev() {
        let pivot = diagonal[i];
        if pivot == 0.0 {
            return None;
        }
        let coefficient = step_rows[i] / pivot;
        step_rows[i] = coefficient;
        let above = &data[i * m..i * m + i];
        for (value, entry) in step_rows[..i].iter_mut().zip(above) {
            *value += -coefficient * entry;
        }
    }
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// nalgebra's `reflection_axis_mut`: turns `column` into the unit axis of the reflection that
/// maps it onto its first coordinate; the value that coordinate becomes, and whether the
/// column was not zero (`false`: the axis is left unscaled).
fn reflection_axis(column: &mut [f64]) -> (f64, bool) {
    let squared = dot(column, column);
    let norm = squared.sqrt();
    let (modulus, sign) = if column[0] >= 0.0 {
        (column[0], 1.0)
    } else {
        (-column[0], -1.0)
    };
    let signed_norm = sign * norm;
    let factor = (squared + modulus * norm) * 2.0;
    column[0] += signed_norm;
    if factor == 0.0 {
        return (signed_norm, false);
    }
    let scale = factor.sqrt();
    for value in column.iter_mut() {
        *value /= scale;
    }
    let length = dot(column, column).sqrt();
    for value in column.iter_mut() {
        *value /= length;
    }
    (-signed_norm, true)
}

/// nalgebra's `Reflection::reflect_with_sign` of one column by the unit `axis` (through the
/// origin, so nalgebra's bias term is zero and left out: `x − 0` is `x` for every `x`):
/// `y ← f a + sign y` with `f = −2 sign (a·y)`.
fn reflect(axis: &[f64], column: &mut [f64], sign: f64) {
    let factor = dot(axis, column) * (sign * -2.0);
    for (value, a) in column.iter_mut().zip(axis) {
        *value = factor * a + sign * *value;
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::{qr_step, WELL_CONDITIONED};
    use crate::solver::column_dot::{awkward, bits};

    /// The step as first written, on nalgebra's `QR`: the reference the slice version must
    /// match bit for bit.
    fn on_nalgebra(jacobian: DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
        let n = jacobian.ncols();
        if jacobian.nrows() < n || n == 0 || !jacobian.iter().all(|v| v.is_finite()) {
            return None;
        }
        let qr = jacobian.qr();
        let triangle = qr.r();
        let diagonal = triangle.diagonal().abs();
        if diagonal.min() <= WELL_CONDITIONED * diagonal.max() {
            return None;
        }
        let mut rotated = r.clone();
        qr.q_tr_mul(&mut rotated);
        let top = rotated.rows(0, n).into_owned();
        let step = triangle.solve_upper_triangular(&top)?;
        step.iter().all(|v| v.is_finite()).then_some(step)
    }

    /// The slice QR step is nalgebra's, bit for bit, on tall and square matrices of both
    /// signs on the diagonal, with a column that starts with zero; both refuse the same
    /// ill-conditioned and wide ones.
    #[test]
    fn the_slice_step_is_nalgebras_bit_for_bit() {
        let bits = |v: &Option<DVector<f64>>| v.as_ref().map(|v| bits(v.as_slice()));
        for (m, n, seed) in [
            (18, 6, 1),
            (37, 6, 2),
            (6, 6, 3),
            (9, 1, 4),
            (40, 9, 5),
            (3, 5, 6),
        ] {
            let mut c = DMatrix::from_vec(m, n, awkward(m * n, seed));
            if n > 1 && m > 1 {
                c[(0, 1)] = 0.0;
                c[(1, 0)] = -c[(1, 0)].abs();
            }
            let r = DVector::from_vec(awkward(m, seed + 50));
            let expected = on_nalgebra(c.clone(), &r);
            assert_eq!(bits(&qr_step(c.clone(), &r)), bits(&expected), "{m}x{n}");
            assert_eq!(expected.is_some(), m >= n, "{m}x{n}");
            // Two equal columns: both refuse.
            if n > 1 {
                let first = c.column(0).into_owned();
                c.set_column(n - 1, &first);
                assert!(qr_step(c.clone(), &r).is_none() && on_nalgebra(c, &r).is_none());
            }
        }
    }

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
