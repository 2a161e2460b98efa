//! The small dense linear algebra of the engines against nalgebra's LU, Cholesky and
//! eigenvalue routines.

// Exact values are asserted where the routines return them exactly (0, −∞).
#![allow(clippy::float_cmp)]

use super::*;
use crate::selection::linalg::{
    det_in_place, half_ln, invert_in_place, ln_det_small, log_det_spd, min_eigenvalue, spd_inverse,
};
use nalgebra::DVector;

/// A random b × b matrix of standard-normal entries.
fn random_square(rng: &mut ChaCha8Rng, b: usize) -> DMatrix<f64> {
    DMatrix::from_fn(b, b, |_, _| rng.sample(StandardNormal))
}

/// `m` row by row, as the in-place routines take it.
fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

/// A symmetric positive-definite n × n matrix `CᵀC + I·shift` whose Jacobi scales span
/// `1e-6 … 1e6`.
fn badly_scaled_spd(rng: &mut ChaCha8Rng, n: usize, shift: f64) -> DMatrix<f64> {
    let c = DMatrix::from_fn(n + 2, n, |_, _| rng.sample::<f64, _>(StandardNormal));
    let core = c.transpose() * c + DMatrix::identity(n, n) * shift;
    let scales = DVector::from_fn(n, |i, _| 10f64.powf(-6.0 + 12.0 * i as f64 / n as f64));
    DMatrix::from_fn(n, n, |i, j| core[(i, j)] * scales[i] * scales[j])
}

#[test]
fn determinants_and_inverses_match_the_lu_factorisation_with_pivoting() {
    let mut rng = ChaCha8Rng::seed_from_u64(800);
    for b in 1..=6 {
        for trial in 0..5 {
            let mut m = random_square(&mut rng, b);
            if trial == 0 && b > 1 {
                // A zero leading entry: the first column needs a row swap.
                m[(0, 0)] = 0.0;
            }
            let expected = m.clone().lu().determinant();
            let det = det_in_place(&mut row_major(&m), b);
            assert!(
                (det - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                "b = {b}: det {det} vs {expected}"
            );
            let mut out = vec![0.0; b * b];
            let det = invert_in_place(&mut row_major(&m), b, &mut out);
            assert!((det - expected).abs() <= 1e-12 * expected.abs().max(1.0));
            let inverse = DMatrix::from_row_slice(b, b, &out);
            let reference = m.clone().try_inverse().unwrap();
            assert!(
                (&inverse - &reference).amax() <= 1e-10 * reference.amax(),
                "b = {b}: inverse off by {}",
                (&inverse - &reference).amax()
            );
            let sign = if expected > 0.0 { 1.0 } else { -1.0 };
            let ln = ln_det_small(&m);
            if sign > 0.0 {
                assert!((ln - expected.ln()).abs() < 1e-12 * expected.ln().abs().max(1.0));
            } else {
                assert_eq!(ln, f64::NEG_INFINITY, "b = {b}: negative determinant");
            }
        }
    }
    // Pivoting on the largest entry: [[1e-20, 1], [1, 1]] has determinant −1 (without
    // the swap, elimination by 1e-20 loses the 1 of the second row).
    let m = DMatrix::from_row_slice(2, 2, &[1e-20, 1.0, 1.0, 1.0]);
    let det = det_in_place(&mut row_major(&m), 2);
    assert!((det + 1.0).abs() < 1e-15, "{det}");
    let mut out = vec![0.0; 4];
    invert_in_place(&mut row_major(&m), 2, &mut out);
    let product = &m * DMatrix::from_row_slice(2, 2, &out);
    assert!((product - DMatrix::identity(2, 2)).amax() < 1e-15);
    // A zero column (at any position) and two equal rows: determinant 0, ln det −∞.
    for singular in [
        DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0, 7.0]),
        DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0, 7.0, 0.0]),
        DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 3.0, 1.0, 2.0, 3.0, 0.0, 0.0, 1.0]),
    ] {
        assert_eq!(det_in_place(&mut row_major(&singular), 3), 0.0);
        assert_eq!(
            invert_in_place(&mut row_major(&singular), 3, &mut [0.0; 9]),
            0.0
        );
        assert_eq!(ln_det_small(&singular), f64::NEG_INFINITY);
    }
}

#[test]
fn the_spd_inverse_and_log_det_are_accurate_whatever_the_scaling() {
    let mut rng = ChaCha8Rng::seed_from_u64(801);
    for n in 1..=6 {
        let m = badly_scaled_spd(&mut rng, n, 0.0);
        let inverse = spd_inverse(&m).unwrap();
        // Symmetric, and M⁻¹M = I to round-off of the scaled problem.
        assert!((&inverse - inverse.transpose()).amax() <= 1e-15 * inverse.amax());
        let scales = m.diagonal().map(|v| v.sqrt());
        let product = &inverse * &m;
        for i in 0..n {
            for j in 0..n {
                let identity = if i == j { 1.0 } else { 0.0 };
                // (M⁻¹M)_ij scales as s_j / s_i.
                let relative = (product[(i, j)] - identity) * scales[i] / scales[j];
                assert!(
                    relative.abs() < 1e-9,
                    "n = {n}: ({i}, {j}) off by {relative}"
                );
            }
        }
        let expected = m.clone().cholesky().unwrap().determinant().ln();
        let ln = log_det_spd(&m);
        assert!(
            (ln - expected).abs() < 1e-10 * expected.abs().max(1.0),
            "{ln} vs {expected}"
        );
    }
}

#[test]
fn matrices_that_are_not_numerically_positive_definite_have_no_inverse_or_log_det() {
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let zero_diagonal = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 0.0]);
    let negative_diagonal = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
    let infinite = DMatrix::from_row_slice(2, 2, &[f64::INFINITY, 0.0, 0.0, 1.0]);
    let not_a_number = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, f64::NAN, 1.0]);
    for (what, m) in [
        ("indefinite", &indefinite),
        ("zero diagonal", &zero_diagonal),
        ("negative diagonal", &negative_diagonal),
        ("infinite", &infinite),
        ("NaN", &not_a_number),
    ] {
        assert!(spd_inverse(m).is_none(), "{what}");
        if what != "NaN" {
            assert_eq!(log_det_spd(m), f64::NEG_INFINITY, "{what}");
        }
    }
    assert_eq!(log_det_spd(&DMatrix::zeros(0, 0)), f64::NEG_INFINITY);
    // The unit-diagonal matrix with every other entry a = 1 − kε/2 has the eigenvalue
    // 1 − a = kε/2 twice: its Cholesky factorisation succeeds, and its inverse's Frobenius
    // norm is about 1.3e16 for k = 1 (beyond 1/RANK_TOLERANCE² = 1e16: singular to double
    // precision) and 3.2e15 for k = 4 (inverted).
    let all_a = |k: f64| {
        let a = 1.0 - k * f64::EPSILON / 2.0;
        DMatrix::from_fn(3, 3, |i, j| if i == j { 1.0 } else { a })
    };
    assert!(all_a(1.0).cholesky().is_some());
    assert!(spd_inverse(&all_a(1.0)).is_none());
    assert!(spd_inverse(&all_a(4.0)).is_some());
    // Ill-conditioned but regular (scaled condition 1e10): inverted.
    let delta = 1e-10;
    let m = DMatrix::from_row_slice(2, 2, &[1.0, 1.0 - delta, 1.0 - delta, 1.0]);
    let inverse = spd_inverse(&m).unwrap();
    let expected = m.clone().try_inverse().unwrap();
    assert!((&inverse - &expected).amax() < 1e-5 * expected.amax());
}

#[test]
fn half_log_and_smallest_eigenvalue() {
    assert!((half_ln(4.0) - 2f64.ln()).abs() < 1e-15);
    assert_eq!(half_ln(0.0), f64::NEG_INFINITY);
    assert_eq!(half_ln(-1.0), f64::NEG_INFINITY);
    assert_eq!(half_ln(f64::NAN), f64::NEG_INFINITY);
    let not_a_number = DMatrix::from_row_slice(2, 2, &[1.0, f64::NAN, 0.0, 1.0]);
    assert_eq!(ln_det_small(&not_a_number), f64::NEG_INFINITY);
    // Q diag(3, −2, 5) Qᵀ for a rotation Q: the smallest eigenvalue is −2.
    let rotation = nalgebra::Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
    let q = DMatrix::from_fn(3, 3, |i, j| rotation[(i, j)]);
    let m =
        &q * DMatrix::from_diagonal(&DVector::from_column_slice(&[3.0, -2.0, 5.0])) * q.transpose();
    assert!((min_eigenvalue(m) + 2.0).abs() < 1e-14);
}
