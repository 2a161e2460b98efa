//! The building blocks of the fit statistics against values known without the code: the
//! Bonferroni outlier thresholds against printed Student-t and normal quantiles, the leverages
//! against the diagonal of J (JᵀJ)⁻¹ Jᵀ by an explicit inverse, the χ² noise test with two
//! degrees of freedom (upper tail e^{−χ²/2} in closed form), the externally studentized
//! residuals of a gross outlier against a brute-force leave-one-out refit, and the figures of
//! the messages, and the χ² tests' rejection rule at its level.
use legwise::identify::statistics::{
    figure, leverages, noise_test, outlier_threshold, rejects, studentized, NOISE_TEST_P,
    OUTLIER_ALPHA,
};
use nalgebra::{DMatrix, DVector};

fn close(actual: f64, expected: f64, relative: f64) {
    assert!(
        (actual - expected).abs() <= relative * expected.abs(),
        "{actual} vs {expected}"
    );
}

/// Quantiles from statistical tables (to 7 figures): two-sided at family level 1 % over `rows`
/// rows is the 1 − 0.01/(2·rows) quantile.
#[test]
fn outlier_thresholds_are_bonferroni_quantiles() {
    assert!((OUTLIER_ALPHA - 0.01).abs() < 1e-15);
    // Normal: 0.995 → 2.575829, 0.9995 → 3.290527.
    close(outlier_threshold(1, None).unwrap(), 2.575_829_3, 1e-7);
    close(outlier_threshold(10, None).unwrap(), 3.290_526_7, 1e-7);
    // No rows counts as one.
    close(outlier_threshold(0, None).unwrap(), 2.575_829_3, 1e-7);
    // Student's t: 10 dof at 0.995 → 3.169273; 5 dof at 0.999 → 5.893430 (rows = 5);
    // 11 dof at 1 − 0.01/36 → 4.797518 (18 rows, 6 parameters).
    close(outlier_threshold(1, Some(10)).unwrap(), 3.169_272_7, 1e-7);
    close(outlier_threshold(5, Some(5)).unwrap(), 5.893_429_5, 1e-7);
    close(outlier_threshold(18, Some(11)).unwrap(), 4.797_517_9, 1e-7);
    assert_eq!(outlier_threshold(18, Some(0)), None);
}

/// Leverages are the diagonal of the hat matrix; a duplicated column changes nothing (the hat
/// matrix projects onto the column space).
#[test]
fn leverages_are_the_diagonal_of_the_hat_matrix() {
    let j = DMatrix::from_row_slice(5, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0, 1.0, 10.0]);
    let hat = &j * (j.transpose() * &j).try_inverse().unwrap() * j.transpose();
    let h = leverages(&j);
    assert_eq!(h.len(), 5);
    for (i, hi) in h.iter().enumerate() {
        close(*hi, hat[(i, i)], 1e-12);
    }
    // Σ h = rank = 2.
    close(h.iter().sum(), 2.0, 1e-12);
    let duplicated = DMatrix::from_fn(5, 3, |i, k| j[(i, k.min(1))]);
    for (a, b) in leverages(&duplicated).iter().zip(&h) {
        close(*a, *b, 1e-10);
    }
    // The same at the scale 1e6 with the third column a combination of the first two, one
    // entry off by 1e-7: its singular value (about 1e-8, relative 1e-15) is below the cut
    // 1e-12 × the largest, so it spans nothing and the leverages are still those of rank 2.
    let combined = DMatrix::from_fn(5, 3, |i, k| {
        let off = if (i, k) == (4, 2) { 1e-7 } else { 0.0 };
        off + 1e6
            * if k < 2 {
                j[(i, k)]
            } else {
                j[(i, 0)] * 0.3 + j[(i, 1)] * 0.7
            }
    });
    for (a, b) in leverages(&combined).iter().zip(&h) {
        close(*a, *b, 1e-9);
    }
    // A Jacobian of zeros spans nothing: every leverage is 0 (no singular value is kept, not
    // even against a largest one of 0).
    assert_eq!(leverages(&DMatrix::zeros(4, 2)), vec![0.0; 4]);
}

/// e = (1, 2, 2), v = (1, 4, 1), one parameter: χ² = 1 + 1 + 4 = 6 on 2 dof, p = e⁻³.
#[test]
fn the_noise_test_of_known_residuals() {
    let test = noise_test(&[1.0, 2.0, 2.0], &[1.0, 4.0, 1.0], 1, 0).unwrap();
    close(test.chi_squared, 6.0, 1e-15);
    assert_eq!(test.degrees_of_freedom, 2);
    close(test.p_value, (-3.0f64).exp(), 1e-12);
    close(test.sigma_ratio, 3f64.sqrt(), 1e-15);
    close(test.residual_sigma, 4.5f64.sqrt(), 1e-15);
    close(test.expected_sigma, 1.5f64.sqrt(), 1e-15);
    assert_eq!(test.excluded, 0);
    assert!(!test.rejected, "p = 0.0498 is above {NOISE_TEST_P}");
    // Ten times the residuals: χ² = 600, p = e⁻³⁰⁰ ≈ 5e-131: rejected; the expected scatter
    // is the same.
    let test = noise_test(&[10.0, 20.0, 20.0], &[1.0, 4.0, 1.0], 1, 3).unwrap();
    close(test.p_value, (-300.0f64).exp(), 1e-9);
    assert!(test.rejected);
    close(test.expected_sigma, 1.5f64.sqrt(), 1e-15);
    assert_eq!(test.excluded, 3);
    // Zero residuals: χ² = 0, p = 1, and the expected scatter is the harmonic-mean one,
    // √(m / Σ 1/v) = √(3 / 2.25).
    let test = noise_test(&[0.0; 3], &[1.0, 4.0, 1.0], 1, 0).unwrap();
    close(test.p_value, 1.0, 1e-15);
    close(test.expected_sigma, (3.0f64 / 2.25).sqrt(), 1e-15);
    assert!(!test.rejected);
    // No redundancy, or a variance that is not positive and finite: no test.
    assert!(noise_test(&[1.0, 2.0], &[1.0, 1.0], 2, 0).is_none());
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            noise_test(&[1.0, 2.0, 2.0], &[1.0, bad, 1.0], 1, 0).is_none(),
            "{bad}"
        );
    }
}

/// A straight line through 8 points, row 3 off by 10⁶ (10⁸ times the scatter): without row 3
/// the sum of squares is 10⁻¹⁵ of the total, so `Σe² − e_i²/(1 − h_ii)` cancels and the code
/// sums the leave-one-out residuals instead. Every t must still equal the brute-force
/// refit's.
#[test]
fn studentized_residuals_of_a_gross_outlier_equal_a_leave_one_out_refit() {
    let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    let noise = [0.01, -0.02, 0.015, 0.0, -0.01, 0.02, -0.005, 0.01];
    let mut ys: Vec<f64> = xs
        .iter()
        .zip(noise)
        .map(|(x, e)| 1.0 + 0.5 * x + e)
        .collect();
    ys[3] += 1e6;
    let j = DMatrix::from_fn(8, 2, |i, k| if k == 0 { 1.0 } else { xs[i] });
    let fit = |rows: &[usize]| -> DVector<f64> {
        let a = DMatrix::from_fn(rows.len(), 2, |i, k| j[(rows[i], k)]);
        let b = DVector::from_fn(rows.len(), |i, _| ys[rows[i]]);
        (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * b
    };
    let all: Vec<usize> = (0..8).collect();
    let beta = fit(&all);
    let e: Vec<f64> = (0..8)
        .map(|i| ys[i] - (beta[0] + beta[1] * xs[i]))
        .collect();
    let t = studentized(&e, &j);
    for i in 0..8 {
        let others: Vec<usize> = (0..8).filter(|&k| k != i).collect();
        let b = fit(&others);
        let sigma2 = others
            .iter()
            .map(|&k| (ys[k] - (b[0] + b[1] * xs[k])).powi(2))
            .sum::<f64>()
            / 5.0;
        let a = DMatrix::from_fn(7, 2, |r, k| j[(others[r], k)]);
        let ji = DVector::from_vec(vec![1.0, xs[i]]);
        let variance = ji.dot(&((a.transpose() * &a).try_inverse().unwrap() * &ji));
        let expected = (ys[i] - (b[0] + b[1] * xs[i])) / (sigma2 * (1.0 + variance)).sqrt();
        let actual = t[i].unwrap_or_else(|| panic!("row {i} has a t"));
        // The outlier's t is ~10⁸: its own leave-one-out σ carries the round-off of a refit
        // through a 10⁶ residual.
        let tolerance = if i == 3 { 1e-4 } else { 1e-6 };
        close(actual, expected, tolerance);
    }
    assert!(t[3].unwrap() > 1e7);
    // m ≤ n + 1: no t at all.
    assert_eq!(
        studentized(&e[..3], &j.rows(0, 3).into_owned()),
        vec![None; 3]
    );
}

#[test]
fn message_figures_have_three_decimals_or_an_exponent() {
    for (value, text) in [
        (0.0, "0.000"),
        (1e-3, "0.001"),
        (-2.5, "-2.500"),
        (9999.0, "9999.000"),
        (1e4, "1.000e4"),
        (9.99e-4, "9.990e-4"),
        (-1.5e-7, "-1.500e-7"),
    ] {
        assert_eq!(figure(value), text, "{value}");
    }
}

/// A χ² test rejects strictly below the level, and when its probability is not a number.
#[test]
fn a_test_rejects_strictly_below_its_level() {
    assert!(!rejects(NOISE_TEST_P), "at the level: kept");
    assert!(rejects(NOISE_TEST_P * (1.0 - f64::EPSILON)));
    assert!(!rejects(NOISE_TEST_P * (1.0 + f64::EPSILON)));
    assert!(rejects(0.0));
    assert!(!rejects(1.0));
    assert!(rejects(f64::NAN), "an undefined probability is not trusted");
}

/// The other-turn warning lists at most eight lines, with an ellipsis only when there are
/// more.
#[test]
fn the_other_turn_warning_lists_eight_lines_at_most() {
    use legwise::identify::statistics::{warnings, LegStatistics, OtherTurn};
    let text = |count: usize| {
        let statistics = LegStatistics {
            other_turn: Some(OtherTurn {
                turns: 1.0,
                rows: count,
                lines: (2..2 + count).collect(),
            }),
            ..Default::default()
        };
        let warnings = warnings(&statistics, "1", "rad", "q1", 0.5);
        assert_eq!(warnings.len(), 1);
        warnings[0].clone()
    };
    assert!(text(3).contains("(lines 2, 3, 4)"), "{}", text(3));
    assert!(
        text(8).contains("(lines 2, 3, 4, 5, 6, 7, 8, 9)"),
        "{}",
        text(8)
    );
    assert!(
        text(9).contains("(lines 2, 3, 4, 5, 6, 7, 8, 9, …)"),
        "{}",
        text(9)
    );
}
