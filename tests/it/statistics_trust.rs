//! Statistics that catch bad data (issue 8): the declared noise block, the χ² noise test
//! (recomputed here from the residuals by finite differences), studentized outliers (checked
//! against a brute-force leave-one-out refit), robust losses, `--drop-outliers`, turn matching,
//! plausibility ranges, duplicate rows, and the exit code 3 of an untrusted result. The
//! fixtures are in `tests/data/` (see its README): `stats_5r_clean.csv` is `legwise simulate
//! --model models/5r.yaml` (seed 2010, 18 selected poses per leg, σ = 1e-4), the others are
//! copies with one defect.
use std::path::PathBuf;
use std::process::{Command, Output};

use approx::assert_relative_eq;
use legwise::identify::estimate::{
    identify, identify_with, FitOptions, LegEstimate, Strategy, StrategyResult, Weighting,
};
use legwise::identify::robust::RobustLoss;
use legwise::identify::statistics::{outlier_threshold, studentized, NOISE_TEST_P};
use legwise::identify::trust::trust_issues;
use legwise::kinematics::inverse::predict_reading;
use legwise::measure::checks::check;
use legwise::measure::file::read;
use legwise::measure::MeasurementSet;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;
use nalgebra::{DMatrix, DVector};
use serde_json::Value;

use crate::support::{bundled, crate_path};

fn data(name: &str) -> PathBuf {
    crate_path(&format!("tests/data/{name}"))
}

fn measurements(mechanism: &Mechanism, name: &str) -> MeasurementSet {
    read(&data(name), mechanism).expect("fixture reads")
}

/// Divide and conquer, Levenberg–Marquardt, with `options`, on a 5R fixture.
fn fit_5r(name: &str, options: FitOptions) -> StrategyResult {
    let mechanism = bundled("5r.yaml");
    let data = measurements(&mechanism, name);
    identify_with(
        &mechanism,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        options,
    )
    .expect("identifies")
}

fn legwise(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).expect("UTF-8")
}

/// A copy of `tests/data/5r_ok.yaml` (old style: noise only in `simulation`) with `extra`
/// appended, written to a temporary directory; returns the load result.
fn load_with(extra: &str) -> legwise::error::Result<Mechanism> {
    let text = std::fs::read_to_string(data("5r_ok.yaml"))
        .expect("fixture")
        .replace(
            "urdf: ../../models/5r.urdf",
            &format!("urdf: {}", crate_path("models/5r.urdf").display()),
        );
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("model.yaml");
    std::fs::write(&path, format!("{text}\n{extra}\n")).expect("written");
    Mechanism::load(&path)
}

fn identified(
    leg: &LegEstimate,
) -> impl Iterator<Item = &legwise::identify::estimate::ParameterEstimate> {
    leg.parameters.iter().filter(|p| p.identified)
}

#[test]
fn the_noise_block_is_validated_and_is_the_simulations_default() {
    let err = load_with("noise: {z: 1.0e-4}").expect_err("z is not measured");
    let message = err.to_string();
    assert!(message.contains("noise.z"), "{message}");
    assert!(message.contains("measured coordinate (x, y)"), "{message}");
    let err = load_with("noise: {readings: -1.0}").expect_err("negative");
    assert!(err.to_string().contains("noise.readings"), "{err}");

    // Old style: no declared noise, the simulation keeps its own.
    let old = load_with("").expect("loads");
    assert_eq!(old.noise, None);
    let simulation = old.simulation.as_ref().expect("simulation");
    assert_relative_eq!(simulation.reading_noise, 1e-4, max_relative = 0.0);
    // The bundled model declares it once; the simulation defaults to it.
    let model = bundled("5r.yaml");
    let noise = model.noise.expect("declared");
    assert_eq!(
        noise.pose.map(f64::to_bits),
        [1e-4, 1e-4, 0.0, 0.0, 0.0, 0.0].map(f64::to_bits)
    );
    assert_relative_eq!(noise.reading, 1e-4, max_relative = 0.0);
    let simulation = model.simulation.as_ref().expect("simulation");
    assert_eq!(
        simulation.pose_noise.map(f64::to_bits),
        noise.pose.map(f64::to_bits)
    );
    assert_relative_eq!(simulation.reading_noise, noise.reading, max_relative = 0.0);
    // simulation.noise still overrides it.
    let both = load_with("noise: {x: 0.5, y: 0.5, readings: 0.5}").expect("loads");
    assert_relative_eq!(
        both.noise.expect("declared").reading,
        0.5,
        max_relative = 0.0
    );
    assert_relative_eq!(
        both.simulation.as_ref().expect("simulation").reading_noise,
        1e-4,
        max_relative = 0.0
    );
}

/// χ² = Σ r_i² / (σ_q² + Σ_c (∂ψ/∂P_c)² σ_c²), with the residuals and the pose gradient
/// recomputed here by the f64 inverse kinematics and central differences.
fn independent_chi_squared(mechanism: &Mechanism, data: &MeasurementSet, leg: &LegEstimate) -> f64 {
    let l = mechanism.leg_index(&leg.leg).expect("leg");
    let model = &mechanism.legs[l];
    let phi: Vec<f64> = leg.parameters.iter().map(|p| p.estimate).collect();
    let noise = mechanism.noise.expect("declared noise");
    let home = &mechanism.home_pose;
    let mut chi_squared = 0.0;
    for block in data.leg_blocks(l) {
        let predicted = predict_reading(model, &phi, &block.pose, home).expect("reachable");
        let mut variance = noise.reading.powi(2);
        for &c in &mechanism.measured {
            let h = 1e-6;
            let (mut up, mut down) = (block.pose, block.pose);
            up[c] += h;
            down[c] -= h;
            let derivative = (predict_reading(model, &phi, &up, home).expect("up")
                - predict_reading(model, &phi, &down, home).expect("down"))
                / (2.0 * h);
            variance += (derivative * noise.pose[c]).powi(2);
        }
        chi_squared += (predicted - block.reading).powi(2) / variance;
    }
    chi_squared
}

/// χ²(12) upper 0.1 % point (statistical tables: 32.909).
const CHI2_12_999: f64 = 32.909;

#[test]
fn the_noise_test_is_the_chi_squared_of_the_residuals_against_the_declared_noise() {
    let mechanism = bundled("5r.yaml");
    for (name, rejected) in [
        ("stats_5r_clean.csv", false),
        ("stats_5r_outlier.csv", true),
    ] {
        let data = measurements(&mechanism, name);
        let result = identify(
            &mechanism,
            &data,
            Strategy::DivideAndConquer,
            SolverKind::LevenbergMarquardt,
        )
        .expect("identifies");
        let leg1 = &result.legs[0];
        let test = leg1.statistics.noise_test.as_ref().expect("tested");
        assert_eq!(test.degrees_of_freedom, 18 - 6);
        let expected = independent_chi_squared(&mechanism, &data, leg1);
        assert_relative_eq!(test.chi_squared, expected, max_relative = 1e-6);
        assert_relative_eq!(
            test.sigma_ratio,
            (expected / 12.0).sqrt(),
            max_relative = 1e-6
        );
        assert_eq!(test.rejected, rejected, "{name}: {test:?}");
        assert_eq!(expected > CHI2_12_999, rejected, "{name}: χ² {expected}");
        assert_eq!(test.p_value < NOISE_TEST_P, rejected);
        assert_eq!(
            trust_issues(std::slice::from_ref(&result)).is_empty(),
            !rejected
        );
    }
}

#[test]
fn studentized_residuals_equal_a_brute_force_leave_one_out_refit() {
    // A straight line through 8 points, one of them an outlier.
    let xs = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    let noise = [0.01, -0.02, 0.015, 0.0, -0.01, 0.02, -0.005, 0.01];
    let mut ys: Vec<f64> = xs
        .iter()
        .zip(noise)
        .map(|(x, e)| 1.0 + 0.5 * x + e)
        .collect();
    ys[3] += 1.0;
    let j = DMatrix::from_fn(8, 2, |i, k| if k == 0 { 1.0 } else { xs[i] });
    let y = DVector::from_vec(ys.clone());
    let fit = |rows: &[usize]| -> DVector<f64> {
        let a = DMatrix::from_fn(rows.len(), 2, |i, k| j[(rows[i], k)]);
        let b = DVector::from_fn(rows.len(), |i, _| y[rows[i]]);
        (a.transpose() * &a).try_inverse().expect("full rank") * a.transpose() * b
    };
    let all: Vec<usize> = (0..8).collect();
    let beta = fit(&all);
    let e: Vec<f64> = (0..8).map(|i| y[i] - (beta[0] + beta[1] * xs[i])).collect();
    let t = studentized(&e, &j);
    for i in 0..8 {
        // Definition: prediction error of row i from the fit without it, over its standard
        // deviation with σ estimated without row i.
        let others: Vec<usize> = (0..8).filter(|&k| k != i).collect();
        let b = fit(&others);
        let sigma2 = others
            .iter()
            .map(|&k| (y[k] - (b[0] + b[1] * xs[k])).powi(2))
            .sum::<f64>()
            / (7 - 2) as f64;
        let a = DMatrix::from_fn(7, 2, |r, k| j[(others[r], k)]);
        let ji = DVector::from_vec(vec![1.0, xs[i]]);
        let variance = ji.dot(&((a.transpose() * &a).try_inverse().expect("inv") * &ji));
        let expected = (y[i] - (b[0] + b[1] * xs[i])) / (sigma2 * (1.0 + variance)).sqrt();
        assert_relative_eq!(t[i].expect("defined"), expected, max_relative = 1e-9);
    }
    assert!(t[3].expect("outlier").abs() > 20.0);
}

#[test]
fn the_gross_outlier_is_named_by_its_line() {
    let result = fit_5r("stats_5r_outlier.csv", FitOptions::default());
    let leg1 = &result.legs[0];
    assert_eq!(leg1.statistics.outliers.len(), 1, "{:?}", leg1.statistics);
    let outlier = &leg1.statistics.outliers[0];
    assert_eq!(outlier.line, Some(6));
    assert!(outlier.t.abs() > 100.0, "{outlier:?}");
    assert!(leg1
        .warnings
        .iter()
        .any(|w| w.contains("line 6 is an outlier")));
    // leg2's rows are clean.
    assert!(result.legs[1].statistics.outliers.is_empty());
    assert!(
        !result.legs[1]
            .statistics
            .noise_test
            .as_ref()
            .expect("tested")
            .rejected
    );
}

#[test]
fn a_tracker_blunder_is_named_by_its_line_and_rejects_the_noise() {
    let result = fit_5r("stats_5r_blunder.csv", FitOptions::default());
    let leg1 = &result.legs[0];
    let lines: Vec<Option<usize>> = leg1.statistics.outliers.iter().map(|o| o.line).collect();
    assert_eq!(lines, [Some(6)]);
    let test = leg1.statistics.noise_test.as_ref().expect("tested");
    assert!(test.rejected && test.sigma_ratio > 5.0, "{test:?}");
}

/// Every identified parameter of `fit` within `k` standard deviations (of `reference`) of
/// `reference`; returns the largest |Δ|/σ.
fn largest_deviation(fit: &StrategyResult, reference: &StrategyResult) -> f64 {
    let mut largest: f64 = 0.0;
    for (leg, clean) in fit.legs.iter().zip(&reference.legs) {
        for (p, q) in identified(leg).zip(identified(clean)) {
            let sigma = q.std.expect("std");
            largest = largest.max((p.estimate - q.estimate).abs() / sigma);
        }
    }
    largest
}

/// A least-squares fit's outlier threshold is the Bonferroni t quantile over the leg's m rows
/// with m − n − 1 degrees of freedom (n identified parameters), recomputed here from the
/// leg's counts; the robust fit's is the normal law's over the same rows. On clean data both
/// noise tests keep every row.
#[test]
fn the_outlier_thresholds_follow_the_legs_rows_and_parameters() {
    let clean = fit_5r("stats_5r_clean.csv", FitOptions::default());
    let robust = fit_5r(
        "stats_5r_clean.csv",
        FitOptions {
            robust: Some(RobustLoss::Huber),
            ..Default::default()
        },
    );
    for (leg, robust_leg) in clean.legs.iter().zip(&robust.legs) {
        let (m, n) = (leg.measurements, identified(leg).count());
        assert!(m > n + 1, "leg {}: {m} rows, {n} parameters", leg.leg);
        assert_eq!(
            leg.statistics.outlier_threshold,
            outlier_threshold(m, Some(m - n - 1)),
            "leg {}",
            leg.leg
        );
        assert_eq!(
            robust_leg.statistics.outlier_threshold,
            outlier_threshold(m, None),
            "leg {}",
            leg.leg
        );
        // No row flagged, none left out of the noise test.
        for fitted in [leg, robust_leg] {
            let test = fitted.statistics.noise_test.as_ref().expect("noise test");
            assert_eq!(
                (test.excluded, test.degrees_of_freedom),
                (0, m - n),
                "leg {}",
                leg.leg
            );
        }
    }
}

#[test]
fn robust_cauchy_and_drop_outliers_recover_the_clean_fit_within_three_sigma() {
    let clean = fit_5r("stats_5r_clean.csv", FitOptions::default());
    let plain = fit_5r("stats_5r_outlier.csv", FitOptions::default());
    assert!(
        largest_deviation(&plain, &clean) > 3.0,
        "the outlier must hurt"
    );
    for options in [
        FitOptions {
            robust: Some(RobustLoss::Cauchy),
            ..Default::default()
        },
        FitOptions {
            drop_outliers: true,
            ..Default::default()
        },
    ] {
        let fit = fit_5r("stats_5r_outlier.csv", options);
        let deviation = largest_deviation(&fit, &clean);
        assert!(deviation < 3.0, "{options:?}: {deviation}σ");
        assert!(
            trust_issues(std::slice::from_ref(&fit)).is_empty(),
            "{options:?}"
        );
        let leg1 = &fit.legs[0];
        if options.drop_outliers {
            assert_eq!(leg1.measurements, 17);
            assert_eq!(leg1.dropped.len(), 1);
            assert_eq!(leg1.dropped[0].line, Some(6));
            assert!(leg1.warnings[0].starts_with("leg leg1: dropped line 6"));
        } else {
            assert_eq!(leg1.statistics.outliers[0].line, Some(6));
            let test = leg1.statistics.noise_test.as_ref().expect("tested");
            assert_eq!((test.excluded, test.degrees_of_freedom), (1, 11));
        }
    }
}

#[test]
fn robust_losses_leave_clean_data_alone() {
    let clean = fit_5r("stats_5r_clean.csv", FitOptions::default());
    for loss in [RobustLoss::Huber, RobustLoss::Cauchy] {
        let fit = fit_5r(
            "stats_5r_clean.csv",
            FitOptions {
                robust: Some(loss),
                ..Default::default()
            },
        );
        assert!(largest_deviation(&fit, &clean) < 0.5, "{loss:?}");
        assert!(fit.legs.iter().all(|l| l.statistics.outliers.is_empty()));
    }
}

/// The losses' weights ρ'(u²) at u = 0, inside Huber's corner, at the tuning constants and far
/// out, on either side (a test of its own: a wrong weight fails it in milliseconds, where a
/// fit with that weight may run long).
#[test]
fn the_robust_weights_at_known_points() {
    for u in [0.0, 1.0, -1.0, 1.345, -1.345] {
        assert_relative_eq!(RobustLoss::Huber.weight(u), 1.0, max_relative = 0.0);
    }
    assert_relative_eq!(RobustLoss::Huber.weight(13.45), 0.1);
    assert_relative_eq!(RobustLoss::Huber.weight(-2.69), 0.5);
    assert_relative_eq!(RobustLoss::Cauchy.weight(0.0), 1.0, max_relative = 0.0);
    assert_relative_eq!(RobustLoss::Cauchy.weight(2.3849), 0.5);
    assert_relative_eq!(RobustLoss::Cauchy.weight(-3.0 * 2.3849), 0.1);
}

#[test]
fn weights_noise_fits_by_the_inverse_expected_variance() {
    let clean = fit_5r("stats_5r_clean.csv", FitOptions::default());
    let weighted = fit_5r(
        "stats_5r_clean.csv",
        FitOptions {
            weights: Weighting::Noise,
            ..Default::default()
        },
    );
    assert!(largest_deviation(&weighted, &clean) < 1.0);
    // Observability is the design's: the unweighted Jacobian's singular values, whatever the
    // weights (the weighted ones would be ~1/σ ≈ 4000 times larger).
    for (leg, reference) in weighted.legs.iter().zip(&clean.legs) {
        let (a, b) = (
            &leg.observability.singular_values,
            &reference.observability.singular_values,
        );
        for (x, y) in a.iter().zip(b.iter()) {
            assert_relative_eq!(*x, *y, max_relative = 1e-2);
        }
    }
    for leg in &weighted.legs {
        // Weighted residuals are standardised: σ̂ is the ratio to the declared scatter (the
        // weights are taken at the nominal parameters, the test at the estimate).
        let test = leg.statistics.noise_test.as_ref().expect("tested");
        let sigma = leg.residual_sigma.expect("redundant");
        assert_relative_eq!(sigma, test.sigma_ratio, max_relative = 0.05);
    }
    let mechanism = bundled("5r.yaml");
    let silent = mechanism.edited(|parts| parts.noise = None);
    let err = identify_with(
        &silent,
        &measurements(&mechanism, "stats_5r_clean.csv"),
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        FitOptions {
            weights: Weighting::Noise,
            ..Default::default()
        },
    )
    .expect_err("no declared noise");
    assert!(err.to_string().contains("noise"), "{err}");
}

#[test]
fn home_values_on_another_turn_or_in_degrees_give_the_clean_offsets_and_a_warning() {
    let clean = fit_5r("stats_5r_clean.csv", FitOptions::default());
    for (model, turns) in [
        ("5r_home_other_turn.yaml", vec![("leg1", "A1", 1)]),
        (
            "5r_home_degrees.yaml",
            vec![("leg1", "A1", 20), ("leg2", "A2", 8)],
        ),
    ] {
        let mechanism = Mechanism::load(&data(model)).expect("loads");
        let result = identify(
            &mechanism,
            &measurements(&mechanism, "stats_5r_clean.csv"),
            Strategy::DivideAndConquer,
            SolverKind::LevenbergMarquardt,
        )
        .expect("identifies");
        for (leg, reference) in result.legs.iter().zip(&clean.legs) {
            for (p, q) in leg.parameters.iter().zip(&reference.parameters) {
                assert!(
                    (p.estimate - q.estimate).abs() < 1e-9,
                    "{model}: {} {} vs {}",
                    p.name,
                    p.estimate,
                    q.estimate
                );
            }
        }
        let warnings: Vec<&String> = result.legs.iter().flat_map(|l| &l.warnings).collect();
        assert_eq!(warnings.len(), turns.len(), "{model}: {warnings:?}");
        for (warning, (leg, joint, n)) in warnings.iter().zip(turns) {
            let head = format!("leg {leg}, joint {joint}: 18 reading(s)");
            assert!(warning.starts_with(&head), "{warning}");
            assert!(warning.contains(&format!("sit {n} turn(s)")), "{warning}");
        }
    }
}

#[test]
fn revolute_readings_are_judged_by_their_joint_value_so_a_geared_actuator_passes() {
    let mechanism = bundled("5r.yaml");
    let clean = measurements(&mechanism, "stats_5r_clean.csv");
    assert!(check(&mechanism, &clean).expect("plausible").is_empty());
    // A 1:50 gear on leg1: readings 50 times the joint angle, gain 1/50.
    let geared = mechanism.edited(|parts| parts.legs[0].gain = 0.02);
    let mut turned = clean.clone();
    for i in 0..turned.len() {
        let readings = turned.readings_mut(i);
        readings[0] = readings[0].map(|r| r * 50.0);
    }
    assert!(check(&geared, &turned).expect("plausible").is_empty());
    // The same readings with gain 1: the joint would sit ~20 turns from home.
    let warnings = check(&mechanism, &turned).expect("warnings only");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].starts_with("column `A1`: revolute reading 36 values, first "),
        "{}",
        warnings[0]
    );
}

#[test]
fn duplicate_rows_are_named_by_both_lines() {
    let result = fit_5r("stats_5r_duplicate.csv", FitOptions::default());
    assert_eq!(result.warnings.len(), 1, "{:?}", result.warnings);
    assert!(result.warnings[0].starts_with("line 7 repeats line 6 exactly"));
}

#[test]
fn positions_in_millimetres_are_an_error_naming_line_and_column() {
    let mechanism = bundled("5r.yaml");
    let err = identify(
        &mechanism,
        &measurements(&mechanism, "stats_5r_millimetres.csv"),
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
    )
    .expect_err("far out");
    let message = err.to_string();
    assert!(message.contains("line 2, column `x`"), "{message}");
    assert!(message.contains("millimetres"), "{message}");
}

/// Runs `legwise identify ARGS`; returns (exit code, stdout, stderr).
fn identify_cli(args: &[&str]) -> (Option<i32>, String, String) {
    let mut all = vec!["identify"];
    all.extend_from_slice(args);
    let out = legwise(&all);
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

#[test]
fn readings_in_degrees_exit_3_with_a_message_about_units() {
    let (code, stdout, stderr) = identify_cli(&[
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/stats_5r_degrees.csv",
    ]);
    assert_eq!(code, Some(3), "{stderr}");
    // One warning line per leg whose residuals reject the declared noise, naming the units.
    let rejected: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("reject the declared noise"))
        .collect();
    assert_eq!(rejected.len(), 2, "{stderr}");
    assert!(
        rejected.iter().all(|l| l.starts_with("legwise: warning: ")
            && l.contains("units")
            && l.contains("degrees")),
        "{stderr}"
    );
    assert!(stdout.contains("\nwarnings (6):\n"), "{stdout}");
    assert!(stdout
        .contains("column `A1`: revolute reading 36 values, first 167.79052248782259 at line 2"));
    assert!(stdout.contains("readings in degrees instead of radians?"));
    assert!(stdout.contains("the residuals reject the declared noise"));
}

#[test]
fn a_3rpr_yaw_in_degrees_exits_3_naming_the_column() {
    let (code, stdout, stderr) = identify_cli(&[
        "--model",
        "models/3rpr.yaml",
        "--measurements",
        "tests/data/stats_3rpr_yaw_degrees.csv",
    ]);
    assert_eq!(code, Some(3), "{stderr}");
    assert!(stdout.contains("column `yaw`: "), "{stdout}");
    assert!(stdout.contains("an orientation in degrees instead of radians?"));
    for leg in ["leg1", "leg2", "leg3"] {
        assert!(
            stderr.contains(&format!(
                "leg `{leg}`: the residuals reject the declared noise"
            )),
            "{stderr}"
        );
    }
    // The clean file passes.
    let (code, _, stderr) = identify_cli(&[
        "--model",
        "models/3rpr.yaml",
        "--measurements",
        "tests/data/stats_3rpr_clean.csv",
    ]);
    assert_eq!(code, Some(0), "{stderr}");
}

#[test]
fn a_reading_of_1e12_is_named_and_dropped() {
    let args = [
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/stats_5r_huge_reading.csv",
    ];
    let (code, stdout, _) = identify_cli(&args);
    assert_eq!(code, Some(3));
    assert!(stdout.contains("column `A1`: revolute reading 1000000000000 at line 6 puts the joint"));
    assert!(
        stdout.contains("leg leg1: line 6 is an outlier"),
        "{stdout}"
    );
    let mut dropping = args.to_vec();
    dropping.push("--drop-outliers");
    let (code, stdout, stderr) = identify_cli(&dropping);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("leg leg1: dropped line 6 (reading 1000000000000"));
}

#[test]
fn the_json_report_holds_the_warnings_the_noise_test_and_the_outliers() {
    let dir = tempfile::tempdir().expect("temp dir");
    let json = dir.path().join("r.json");
    let (code, _, _) = identify_cli(&[
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/stats_5r_outlier.csv",
        "--robust",
        "cauchy",
        "--json",
        json.to_str().expect("UTF-8 path"),
    ]);
    assert_eq!(code, Some(0));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("written")).expect("JSON");
    let result = &report["results"][0];
    assert_eq!(result["robust"], "cauchy");
    assert_eq!(result["weights"], "none");
    let warnings = result["warnings"].as_array().expect("warnings");
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0]
        .as_str()
        .expect("text")
        .contains("line 6 is an outlier"));
    let leg1 = &result["legs"][0];
    assert_eq!(leg1["outliers"][0]["line"], 6);
    assert_eq!(leg1["noise_test"]["rejected"], false);
    assert_eq!(leg1["noise_test"]["excluded_rows"], 1);
    assert_eq!(leg1["warnings"].as_array().expect("leg warnings").len(), 1);
}
