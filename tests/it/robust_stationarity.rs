//! A robust fit minimises Σ ρ(u_i²) with u_i = r_i/σ_i, so at its estimate the weighted normal
//! equations Σ_i w_i r_i ∂r_i/∂θ_j = 0 hold with w_i = ρ'(u_i²)/σ_i² taken at that same
//! estimate. Checked here on the 5R data with one gross outlier, for Huber and Cauchy, with
//! everything rebuilt outside the fit: the residuals by the f64 inverse kinematics, their
//! parameter derivatives and pose gradients by central differences, σ_i² = σ_q² + Σ_c
//! (∂ψ/∂P_c · σ_c)² at the least-squares estimate (where the fit takes its scale), and the
//! weights from the losses' formulas (Huber min(1, c/|u|) with c = 1.345, Cauchy
//! 1/(1 + (u/c)²) with c = 2.3849). And the robust fit's outlier statistics: standardised
//! residuals t_i = r_i/(σ_i √(1 − h_ii)), h from the explicit hat matrix of the σ-scaled
//! Jacobian, against the normal law's Bonferroni quantile (printed tables: 3.452433 for
//! 18 rows at family level 1 %).
use legwise::identify::estimate::{identify_with, FitOptions, Strategy, StrategyResult};
use legwise::identify::robust::RobustLoss;
use legwise::kinematics::inverse::predict_reading;
use legwise::measure::file::read;
use legwise::measure::MeasurementSet;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;
use nalgebra::DMatrix;

use crate::support::{bundled, crate_path};

fn weight(loss: RobustLoss, u: f64) -> f64 {
    match loss {
        RobustLoss::Huber => {
            let c = 1.345;
            if u.abs() <= c {
                1.0
            } else {
                c / u.abs()
            }
        }
        RobustLoss::Cauchy => 1.0 / (1.0 + (u / 2.3849) * (u / 2.3849)),
    }
}

/// One leg's measurement row rebuilt outside the fit.
struct Row {
    line: usize,
    /// Predicted minus measured reading at the estimate.
    r: f64,
    /// σ_q² + Σ_c (∂ψ/∂P_c · σ_c)² at `phi_variance`.
    variance: f64,
    /// ∂r/∂θ over the identified parameters, by central differences.
    derivatives: Vec<f64>,
}

fn rows(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    l: usize,
    phi: &[f64],
    phi_variance: &[f64],
) -> Vec<Row> {
    let model = &mechanism.legs[l];
    let noise = mechanism.noise.expect("declared noise");
    let home = mechanism.home_pose;
    let reading =
        |phi: &[f64], pose: &[f64; 6]| predict_reading(model, phi, pose, &home).expect("reachable");
    data.leg_blocks(l)
        .iter()
        .map(|block| {
            let mut variance = noise.reading.powi(2);
            for &c in &mechanism.measured {
                let h = 1e-6;
                let (mut up, mut down) = (block.pose, block.pose);
                up[c] += h;
                down[c] -= h;
                let derivative =
                    (reading(phi_variance, &up) - reading(phi_variance, &down)) / (2.0 * h);
                variance += (derivative * noise.pose[c]).powi(2);
            }
            let derivatives = model
                .identified()
                .iter()
                .map(|&j| {
                    let h = 1e-7 * (1.0 + phi[j].abs());
                    let (mut up, mut down) = (phi.to_vec(), phi.to_vec());
                    up[j] += h;
                    down[j] -= h;
                    (reading(&up, &block.pose) - reading(&down, &block.pose)) / (2.0 * h)
                })
                .collect();
            Row {
                line: block.line.expect("read from a file"),
                r: reading(phi, &block.pose) - block.reading,
                variance,
                derivatives,
            }
        })
        .collect()
}

fn estimates(result: &StrategyResult, l: usize) -> Vec<f64> {
    result.legs[l]
        .parameters
        .iter()
        .map(|p| p.estimate)
        .collect()
}

fn outlier_data() -> (Mechanism, MeasurementSet) {
    let mechanism = bundled("5r.yaml");
    let data = read(&crate_path("tests/data/stats_5r_outlier.csv"), &mechanism).unwrap();
    (mechanism, data)
}

fn robust_fit(mechanism: &Mechanism, data: &MeasurementSet, loss: RobustLoss) -> StrategyResult {
    identify_with(
        mechanism,
        data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        FitOptions {
            robust: Some(loss),
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn robust_estimates_solve_their_weighted_normal_equations() {
    let (mechanism, data) = outlier_data();
    let plain = crate::support::identify_unweighted(
        &mechanism,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
    )
    .unwrap();
    for loss in [RobustLoss::Huber, RobustLoss::Cauchy] {
        let robust = robust_fit(&mechanism, &data, loss);
        for l in 0..mechanism.legs.len() {
            let model = &mechanism.legs[l];
            // The fit takes each row's scale at the least-squares estimate.
            let rows = rows(
                &mechanism,
                &data,
                l,
                &estimates(&robust, l),
                &estimates(&plain, l),
            );
            let columns = model.identified();
            let mut gradient = vec![0.0; columns.len()];
            let mut scale = vec![0.0; columns.len()];
            let mut downweighted = 0;
            for row in &rows {
                let w = weight(loss, row.r / row.variance.sqrt()) / row.variance;
                if w * row.variance < 0.5 {
                    downweighted += 1;
                }
                for (k, derivative) in row.derivatives.iter().enumerate() {
                    gradient[k] += w * row.r * derivative;
                    scale[k] += (w * row.r * derivative).abs();
                }
            }
            for (k, &j) in columns.iter().enumerate() {
                assert!(
                    gradient[k].abs() <= 1e-5 * scale[k],
                    "{loss:?} {}: Σ w r ∂r/∂{} = {:e} (scale {:e})",
                    model.name,
                    model.params[j].name,
                    gradient[k],
                    scale[k]
                );
            }
            // The outlier (leg1, line 6, 1000σ) is the one row the loss all but ignores.
            let expected = usize::from(l == 0);
            assert_eq!(downweighted, expected, "{loss:?} {}", model.name);
        }
    }
}

#[test]
fn a_robust_fit_flags_rows_by_their_standardised_residuals() {
    let (mechanism, data) = outlier_data();
    let robust = robust_fit(&mechanism, &data, RobustLoss::Cauchy);
    for (l, leg) in robust.legs.iter().enumerate() {
        let phi = estimates(&robust, l);
        let rows = rows(&mechanism, &data, l, &phi, &phi);
        let m = rows.len();
        assert_eq!(m, 18);
        let n = rows[0].derivatives.len();
        let j = DMatrix::from_fn(m, n, |i, k| {
            rows[i].derivatives[k] / rows[i].variance.sqrt()
        });
        let hat = &j * (j.transpose() * &j).try_inverse().unwrap() * j.transpose();
        let t: Vec<f64> = (0..m)
            .map(|i| rows[i].r / (rows[i].variance.sqrt() * (1.0 - hat[(i, i)]).sqrt()))
            .collect();
        let largest = t.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let reported = leg.statistics.largest_t.expect("a t");
        assert!(
            (reported - largest).abs() <= 1e-4 * largest,
            "{}: largest |t| {reported} vs {largest}",
            leg.leg
        );
        let threshold = leg.statistics.outlier_threshold.expect("a threshold");
        assert!((threshold - 3.452_433).abs() < 1e-6, "{threshold}");
        let mut flagged: Vec<usize> = (0..m)
            .filter(|&i| t[i].abs() > threshold)
            .map(|i| rows[i].line)
            .collect();
        flagged.sort_unstable();
        let mut reported: Vec<usize> = leg
            .statistics
            .outliers
            .iter()
            .map(|o| o.line.unwrap())
            .collect();
        reported.sort_unstable();
        assert_eq!(reported, flagged, "{}", leg.leg);
        assert_eq!(
            flagged.is_empty(),
            l != 0,
            "{}: only leg1 has an outlier",
            leg.leg
        );
    }
}

/// A robust fit's σ: the declared-noise weighted covariance at its estimate over the rows it
/// does not flag, `s² (J̃ᵀJ̃)⁻¹` with `J̃` the σ-scaled Jacobian (`s² = Σ (r/σ)² / (m − n)` on 12
/// or more residual degrees of freedom, 1 below: the declared noise's), times the loss's
/// asymptotic variance factor `E[ψ²] / E[ψ']²` at the normal law: Huber's closed form
/// `(2Φ(c) − 1 − 2cφ(c) + 2c²(1 − Φ(c))) / (2Φ(c) − 1)²` and Cauchy's Simpson sum (80 000
/// intervals on [−40, 40]), both evaluated in Python. Leg1 keeps 17 rows (11 degrees of freedom: unscaled), leg2 all 18 (scaled).
#[test]
fn a_robust_fit_reports_the_weighted_covariance_times_the_loss_factor() {
    // Python: statistics.NormalDist, c = 1.345.
    let huber = 1.052_631_291_188_037_8;
    let (mechanism, data) = outlier_data();
    for (loss, factor) in [
        (RobustLoss::Huber, huber),
        (RobustLoss::Cauchy, 1.052_634_158_1),
    ] {
        let robust = robust_fit(&mechanism, &data, loss);
        for (l, leg) in robust.legs.iter().enumerate() {
            let phi = estimates(&robust, l);
            let flagged: Vec<usize> = leg
                .statistics
                .outliers
                .iter()
                .map(|o| o.line.unwrap())
                .collect();
            let rows: Vec<Row> = rows(&mechanism, &data, l, &phi, &phi)
                .into_iter()
                .filter(|row| !flagged.contains(&row.line))
                .collect();
            let (m, n) = (rows.len(), rows[0].derivatives.len());
            assert_eq!(m, if l == 0 { 17 } else { 18 }, "{loss:?} {}", leg.leg);
            let j = DMatrix::from_fn(m, n, |i, k| {
                rows[i].derivatives[k] / rows[i].variance.sqrt()
            });
            let squares: f64 = rows.iter().map(|row| row.r * row.r / row.variance).sum();
            let scale = if m - n >= 12 {
                squares / (m - n) as f64
            } else {
                1.0
            };
            let covariance = (j.transpose() * &j).try_inverse().unwrap() * (scale * factor);
            let reported: Vec<f64> = leg.parameters.iter().filter_map(|p| p.std).collect();
            assert_eq!(reported.len(), n);
            for (k, std) in reported.iter().enumerate() {
                let expected = covariance[(k, k)].sqrt();
                assert!(
                    (std - expected).abs() <= 1e-5 * expected,
                    "{loss:?} {} parameter {k}: σ {std:e} vs {expected:e}",
                    leg.leg
                );
            }
        }
    }
}
