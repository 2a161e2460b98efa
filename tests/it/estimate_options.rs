//! What `identify_with` does with the declared noise and with `--drop-outliers`, checked by
//! properties that do not go through the code under test: a noise block of zeros is no noise
//! at all; a readings-only noise gives every row the same weight 1/σ_q², which cannot move the
//! estimate or its standard deviations and divides σ̂ by σ_q (recomputed from the reported row
//! residuals); a pose-only noise is a declared noise too; and `--drop-outliers` refits exactly
//! once, even when the refit reveals an outlier the first fit's large one was masking.
//! The default fit of a model with a declared noise is weighted, by the variances at the
//! estimate (its final cost recomputed here with finite-difference gradients).
use legwise::error::Error;
use legwise::identify::estimate::{
    identify_with, FitOptions, LegEstimate, Strategy, StrategyResult, Weighting,
};
use legwise::identify::robust::RobustLoss;
use legwise::measure::file::read;
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;

use crate::support::{bundled, crate_path};

fn fit(
    mechanism: &Mechanism,
    csv: &std::path::Path,
    options: FitOptions,
) -> Result<StrategyResult, Error> {
    let data = read(csv, mechanism).expect("fixture reads");
    identify_with(
        mechanism,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        options,
    )
}

fn clean_csv() -> std::path::PathBuf {
    crate_path("tests/data/stats_5r_clean.csv")
}

fn with_noise(pose_sigma: f64, reading_sigma: f64) -> Mechanism {
    bundled("5r.yaml").edited(|parts| {
        parts.noise = Some(MeasurementNoise {
            pose: [pose_sigma, pose_sigma, 0.0, 0.0, 0.0, 0.0],
            reading: reading_sigma,
            scale: 1.0,
        });
    })
}

const WEIGHTED: FitOptions = FitOptions {
    weights: Weighting::Noise,
    robust: None,
    drop_outliers: false,
    noise_scale: 1.0,
};

/// √(Σ r²/(m − n)) from the reported row residuals.
fn sigma_from_rows(leg: &LegEstimate) -> f64 {
    let n = leg.parameters.iter().filter(|p| p.identified).count();
    let m = leg.residuals.len();
    let squares: f64 = leg.residuals.iter().map(|r| r.residual * r.residual).sum();
    (squares / (m - n) as f64).sqrt()
}

#[test]
fn a_noise_block_of_zeros_is_no_declared_noise() {
    let silent = bundled("5r.yaml").edited(|parts| parts.noise = None);
    let zeros = with_noise(0.0, 0.0);
    let robust = FitOptions {
        robust: Some(RobustLoss::Huber),
        ..Default::default()
    };
    for (options, option) in [(WEIGHTED, "--weights noise"), (robust, "--robust huber")] {
        let without = fit(&silent, &clean_csv(), options)
            .expect_err("no noise")
            .to_string();
        let zero = fit(&zeros, &clean_csv(), options)
            .expect_err("zero noise")
            .to_string();
        assert!(
            without.contains(&format!("{option} needs the measurement noise")),
            "{without}"
        );
        // Not "a row's expected residual variance is zero": the zeros are no noise at all.
        assert_eq!(zero, without);
    }
    // Plain least squares runs without a noise test.
    let plain = fit(&zeros, &clean_csv(), FitOptions::default()).expect("fits");
    assert!(plain.legs.iter().all(|l| l.statistics.noise_test.is_none()));
}

#[test]
fn a_readings_only_noise_weights_every_row_alike() {
    let sigma_q = 2.0e-4;
    let readings_only = with_noise(0.0, sigma_q);
    let plain = fit(&readings_only, &clean_csv(), crate::support::unweighted()).expect("fits");
    let weighted =
        fit(&readings_only, &clean_csv(), WEIGHTED).expect("a readings noise is a noise");
    for (w, p) in weighted.legs.iter().zip(&plain.legs) {
        assert!(p.statistics.noise_test.is_some(), "{}: noise test", p.leg);
        assert_eq!(w.measurements, p.measurements);
        for (a, b) in w.parameters.iter().zip(&p.parameters) {
            assert!(
                (a.estimate - b.estimate).abs() <= 1e-9 * b.estimate.abs().max(1.0),
                "{}: {} vs {}",
                a.name,
                a.estimate,
                b.estimate
            );
            // std = (σ̂/σ_q)·σ_q·√diag((CᵀC)⁻¹): a uniform weight cancels.
            if let (Some(sa), Some(sb)) = (a.std, b.std) {
                assert!(
                    (sa - sb).abs() <= 1e-6 * sb,
                    "std of {}: {sa} vs {sb}",
                    a.name
                );
            } else {
                assert_eq!((a.std, b.std), (None, None), "{}", a.name);
            }
        }
        let sigma = sigma_from_rows(p);
        let reported_plain = p.residual_sigma.expect("redundant");
        let reported_weighted = w.residual_sigma.expect("redundant");
        assert!(
            (reported_plain - sigma).abs() <= 1e-6 * sigma,
            "{reported_plain} vs {sigma}"
        );
        assert!(
            (reported_weighted - sigma / sigma_q).abs() <= 1e-6 * sigma / sigma_q,
            "weighted σ̂ {reported_weighted} vs {}",
            sigma / sigma_q
        );
        // ½‖r_w‖² = ½‖r‖²/σ_q².
        let cost = p.final_cost / (sigma_q * sigma_q);
        assert!(
            (w.final_cost - cost).abs() <= 1e-6 * cost,
            "{} vs {cost}",
            w.final_cost
        );
    }
}

#[test]
fn a_pose_only_noise_is_a_declared_noise() {
    let pose_only = with_noise(1.0e-4, 0.0);
    let plain = fit(&pose_only, &clean_csv(), FitOptions::default()).expect("fits");
    for leg in &plain.legs {
        let test = leg.statistics.noise_test.as_ref().expect("tested");
        assert!(test.expected_sigma > 0.0, "{}", leg.leg);
    }
    let weighted = fit(&pose_only, &clean_csv(), WEIGHTED).expect("a pose noise is a noise");
    assert_eq!(weighted.legs.len(), 2);
}

/// Line 6 off by 0.1 rad (1000σ) hides line 3 off by 0.005 rad (50σ): with the large one in,
/// σ̂ is ~0.03 rad and line 3 looks normal. Dropping line 6 and refitting reveals line 3 as an
/// outlier, which `--drop-outliers` reports but does not drop: it refits once.
#[test]
fn drop_outliers_refits_once_even_when_the_refit_finds_a_masked_outlier() {
    let text = std::fs::read_to_string(clean_csv()).unwrap();
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(index, line)| {
            let shift = match index + 1 {
                3 => 0.005,
                6 => 0.1,
                _ => return line.to_string(),
            };
            let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
            let reading: f64 = cells[3].parse().unwrap();
            cells[3] = format!("{}", reading + shift);
            cells.join(",")
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("masked.csv");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let mechanism = bundled("5r.yaml");

    let first = fit(&mechanism, &csv, FitOptions::default()).expect("fits");
    let flagged: Vec<Option<usize>> = first.legs[0]
        .statistics
        .outliers
        .iter()
        .map(|o| o.line)
        .collect();
    assert_eq!(flagged, vec![Some(6)], "line 3 is masked in the first fit");

    let dropped = fit(
        &mechanism,
        &csv,
        FitOptions {
            drop_outliers: true,
            ..Default::default()
        },
    )
    .expect("fits");
    let leg1 = &dropped.legs[0];
    assert_eq!(leg1.measurements, 17, "one row dropped");
    let gone: Vec<Option<usize>> = leg1.dropped.iter().map(|o| o.line).collect();
    assert_eq!(gone, vec![Some(6)]);
    let revealed: Vec<Option<usize>> = leg1.statistics.outliers.iter().map(|o| o.line).collect();
    assert_eq!(revealed, vec![Some(3)], "reported, not dropped");
    assert_eq!(dropped.legs[1].measurements, first.legs[1].measurements);
}

/// The default fit of a model that declares its noise is the weighted one, and the weights are
/// those of the estimate: the reported final cost is ½ Σ r_i²/v_i with each row's expected
/// variance v_i = σ_q² + Σ_c (σ_c ∂ψ/∂P_c)² recomputed here at the estimate, the gradient by
/// central differences of the leg's predicted reading. The same sum with the variances at the
/// nominal parameters (where the weights start) is measurably different, so the test tells
/// the two apart. Without a declared noise the default is unweighted.
#[test]
fn the_default_fit_is_weighted_by_the_declared_noise_at_the_estimate() {
    use legwise::kinematics::inverse::predict_reading;
    let mechanism = bundled("5r.yaml");
    let data = read(&crate_path("tests/data/stats_5r_clean.csv"), &mechanism).unwrap();
    let default = fit(&mechanism, &clean_csv(), FitOptions::default()).unwrap();
    let explicit = fit(&mechanism, &clean_csv(), WEIGHTED).unwrap();
    assert_eq!(default.options.weights, Weighting::Noise);
    let noise = mechanism.noise.expect("the 5R declares its noise");
    for (l, leg) in default.legs.iter().enumerate() {
        assert_eq!(format!("{leg:?}"), format!("{:?}", explicit.legs[l]));
        let model = &mechanism.legs[l];
        let estimate: Vec<f64> = leg.parameters.iter().map(|p| p.estimate).collect();
        let nominal: Vec<f64> = leg.parameters.iter().map(|p| p.nominal).collect();
        let variance = |phi: &[f64], pose: &[f64; 6]| {
            let mut v = noise.reading.powi(2);
            for c in 0..6 {
                let h = 1e-6;
                let (mut up, mut down) = (*pose, *pose);
                up[c] += h;
                down[c] -= h;
                let at =
                    |p: &[f64; 6]| predict_reading(model, phi, p, &mechanism.home_pose).unwrap();
                let gradient = (at(&up) - at(&down)) / (2.0 * h);
                v += (gradient * noise.pose[c]).powi(2);
            }
            v
        };
        let blocks = data.leg_blocks(l);
        assert_eq!(blocks.len(), leg.residuals.len());
        let cost_with = |phi: &[f64]| -> f64 {
            let terms = blocks.iter().zip(&leg.residuals);
            0.5 * terms
                .map(|(b, r)| r.residual.powi(2) / variance(phi, &b.pose))
                .sum::<f64>()
        };
        let at_estimate = cost_with(&estimate);
        let at_nominal = cost_with(&nominal);
        assert!(
            (leg.final_cost - at_estimate).abs() <= 1e-7 * at_estimate,
            "{}: reported {} against {at_estimate} at the estimate",
            leg.leg,
            leg.final_cost
        );
        assert!(
            (at_nominal - at_estimate).abs() > 1e-5 * at_estimate,
            "{}: the weights at the nominal parameters give {at_nominal}, too close to tell",
            leg.leg
        );
    }
    let quiet = mechanism.edited(|parts| parts.noise = None);
    let unweighted = fit(&quiet, &clean_csv(), FitOptions::default()).unwrap();
    assert_eq!(unweighted.options.weights, Weighting::Unweighted);
    let plain = fit(&quiet, &clean_csv(), crate::support::unweighted()).unwrap();
    assert_eq!(
        format!("{:?}", unweighted.legs),
        format!("{:?}", plain.legs)
    );
}

/// Swamping: in `tests/data/swamping_5r.csv` leg1 has 16 poses near the centre and two far
/// apart (high leverage); the reading of the second far one (line 19) is 5 mrad off. Its
/// pull on the fit gives the other far row (line 18) a studentized residual beyond the
/// threshold too (the first fit flags lines 19 and 18). Refitted without line 19, line 18 is
/// clean: only line 19 is an outlier, and `--drop-outliers` drops it alone, weighted or not.
#[test]
fn an_outlier_on_a_high_leverage_row_is_the_only_row_flagged_and_dropped() {
    let mechanism = bundled("5r.yaml");
    let csv = crate_path("tests/data/swamping_5r.csv");
    let lines = |outliers: &[legwise::identify::statistics::Outlier]| -> Vec<usize> {
        outliers.iter().map(|o| o.line.unwrap()).collect()
    };
    for weights in [Weighting::Noise, Weighting::Unweighted] {
        let options = FitOptions {
            weights,
            ..FitOptions::default()
        };
        let flagged = fit(&mechanism, &csv, options).unwrap();
        assert_eq!(
            lines(&flagged.legs[0].statistics.outliers),
            [19],
            "{weights:?}"
        );
        let dropping = FitOptions {
            drop_outliers: true,
            ..options
        };
        let refit = fit(&mechanism, &csv, dropping).unwrap();
        assert_eq!(lines(&refit.legs[0].dropped), [19], "{weights:?}");
        assert!(refit.legs[0].statistics.outliers.is_empty(), "{weights:?}");
        assert_eq!(refit.legs[0].measurements, 17);
        assert!(refit.legs[1].dropped.is_empty());
    }
}

/// The weighted fit reports the work of every fit it made: the first one from the nominal
/// parameters, which goes about as far as the unweighted fit from the same start (the same rows,
/// reweighted by 1.4–2×), and each reweighting round after it. So on the bundled 5R's clean
/// file its iterations, residual and Jacobian evaluations are at least the unweighted fit's,
/// leg by leg (iterations 6 against 4 and 9 against 6); counting the last refit alone would
/// give 0 (it starts where the previous round converged).
///
/// And no more than twice the unweighted fit's residual evaluations (12 against 9 and 19
/// against 10): the rounds while the weights still move are one Gauss–Newton step each, not
/// a full solve (full solves every round took 22 and 32).
#[test]
fn the_weighted_fit_counts_the_work_of_every_reweighting() {
    let mechanism = bundled("5r.yaml");
    let unweighted = FitOptions {
        weights: Weighting::Unweighted,
        ..WEIGHTED
    };
    // Per leg: iterations, residual and Jacobian evaluations.
    let runs = |options: FitOptions| -> Vec<[u64; 3]> {
        let result = fit(&mechanism, &clean_csv(), options).unwrap();
        result
            .runs
            .iter()
            .map(|run| {
                [
                    run.iterations,
                    run.residual_evaluations,
                    run.jacobian_evaluations,
                ]
            })
            .collect()
    };
    let (weighted, plain) = (runs(WEIGHTED), runs(unweighted));
    assert_eq!(weighted.len(), 2);
    for (w, p) in weighted.iter().zip(&plain) {
        for k in 0..3 {
            assert!(
                w[k] >= p[k],
                "weighted {weighted:?} against unweighted {plain:?}"
            );
        }
        assert!(
            w[1] <= 2 * p[1],
            "weighted {weighted:?} against unweighted {plain:?}"
        );
    }
}
