//! The calibrated model: identified values written in place of the nominal ones (URDF joint
//! origins, actuator gains and offsets, attachments); identifying again from it on the same
//! data is a fixed point reached without iterating; inputs are never overwritten. Also the
//! identify report's per-leg covariance and row residuals, recomputed independently.
use std::path::Path;
use std::process::Command;

use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::file;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use legwise::report::calibrated::{calibrated_files, urdf_path, Calibration};
use legwise::solver::SolverKind;
use nalgebra::DVector;

use crate::support::{bundled, crate_path};

#[test]
fn identifying_again_from_the_calibrated_model_is_a_fixed_point_without_iterations() {
    for name in ["5r.yaml", "3rpr.yaml"] {
        let dir = tempfile::tempdir().unwrap();
        let mechanism = bundled(name);
        let experiment = simulate(&mechanism, SimulationOptions::default()).unwrap();
        let csv = dir.path().join("measurements.csv");
        file::write(&csv, &mechanism, &experiment.measurements).unwrap();
        let data = file::read(&csv, &mechanism).unwrap();
        let solver = SolverKind::LevenbergMarquardt;
        let result = identify(&mechanism, &data, Strategy::DivideAndConquer, solver).unwrap();
        let out = dir.path().join("calibrated.yaml");
        let calibration = Calibration {
            mechanism: &mechanism,
            result: &result,
            source: &csv.display().to_string(),
            real: None,
            note: None,
        };
        let urdf = urdf_path(&out).unwrap();
        assert_eq!(urdf, dir.path().join("calibrated.urdf"));
        let files = calibrated_files(&calibration, "calibrated.urdf").unwrap();
        std::fs::write(&urdf, &files.urdf).unwrap();
        std::fs::write(&out, &files.yaml).unwrap();

        let calibrated = Mechanism::load(&out).unwrap();
        assert_eq!(calibrated.urdf_path, urdf);
        // Every identified value is the calibrated model's nominal value, exactly.
        for (leg, estimate) in calibrated.legs.iter().zip(&result.legs) {
            for (param, p) in leg.params.iter().zip(&estimate.parameters) {
                assert_eq!(param.nominal.to_bits(), p.estimate.to_bits(), "{}", p.name);
            }
        }
        let again = identify(&calibrated, &data, Strategy::DivideAndConquer, solver).unwrap();
        for run in &again.runs {
            assert_eq!(run.iterations, 0, "{name}: {run:?}");
        }
        for (a, b) in again.legs.iter().zip(&result.legs) {
            for (pa, pb) in a.parameters.iter().zip(&b.parameters) {
                assert!((pa.estimate - pb.estimate).abs() <= 1e-10, "{}", pa.name);
            }
        }
        // The header says where the values came from, and gives every parameter's σ.
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.contains(&format!("# Identified from: {}", csv.display())));
        assert!(text.contains("Strategy: divide and conquer; solver: Levenberg-Marquardt"));
        for p in result.legs.iter().flat_map(|l| &l.parameters) {
            let line = text
                .lines()
                .find(|l| l.starts_with("#   ") && l.contains(&format!(": {} = ", p.name)))
                .unwrap_or_else(|| panic!("no comment line for {}", p.name));
            assert!(line.contains("σ = "), "{line}");
        }
    }
}

#[test]
fn outputs_that_would_overwrite_an_input_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    for file_name in ["5r.yaml", "5r.urdf"] {
        std::fs::copy(
            crate_path(&format!("models/{file_name}")),
            dir.path().join(file_name),
        )
        .unwrap();
    }
    let csv = dir.path().join("m.csv");
    std::fs::copy(crate_path("tests/data/valid.csv"), &csv).unwrap();
    let snapshot =
        || ["5r.yaml", "5r.urdf", "m.csv"].map(|f| std::fs::read(dir.path().join(f)).unwrap());
    let originals = snapshot();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    let model = dir.path().join("5r.yaml");
    for (out, expected) in [
        (model.clone(), "would overwrite the model file"),
        // Its URDF would be 5r.urdf, the model's URDF, reached through another path.
        (sub.join("../5r.yml"), "would overwrite the URDF"),
        (csv.clone(), "would overwrite the measurement file"),
        (dir.path().join("m.urdf"), "another extension than .urdf"),
    ] {
        let output = legwise(&[
            "identify",
            "--model",
            model.to_str().unwrap(),
            "--measurements",
            csv.to_str().unwrap(),
            "--calibrated",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{out:?}: {stderr}");
        assert!(stderr.contains(expected), "{out:?}: {stderr}");
        assert!(output.stdout.is_empty(), "refused before identifying");
    }
    assert_eq!(snapshot(), originals);
    // Two outputs of one run naming the same file.
    let out = dir.path().join("cal.yaml");
    let output = legwise(&[
        "identify",
        "--model",
        model.to_str().unwrap(),
        "--measurements",
        csv.to_str().unwrap(),
        "--calibrated",
        out.to_str().unwrap(),
        "--json",
        sub.join("../cal.urdf").to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains("would write the same file"));
    assert!(!out.exists());
}

#[test]
fn covariance_and_row_residuals_match_an_independent_recomputation() {
    let mechanism = bundled("5r.yaml");
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("m.csv");
    let experiment = simulate(&mechanism, SimulationOptions::default()).unwrap();
    file::write(&csv, &mechanism, &experiment.measurements).unwrap();
    let data = file::read(&csv, &mechanism).unwrap();
    // Without a declared noise: the homoscedastic covariance recomputed below.
    let result = crate::support::identify_unweighted(
        &mechanism.edited(|parts| parts.noise = None),
        &data,
        Strategy::DivideAndConquer,
        SolverKind::GaussNewton,
    )
    .unwrap();
    for (l, estimate) in result.legs.iter().enumerate() {
        let problem = IdentificationProblem::new(&mechanism, &[l], data.leg_blocks(l));
        let x = DVector::from_iterator(6, estimate.parameters.iter().map(|p| p.estimate));
        let (r, c) = problem.residuals_and_jacobian(&x).unwrap();
        let (m, n) = (c.nrows(), c.ncols());
        let sigma2 = r.norm_squared() / (m - n) as f64;
        // Explicit normal-equation inverse here, as an independent check of the SVD form.
        let expected = (c.transpose() * &c).try_inverse().unwrap() * sigma2;
        let covariance = estimate.covariance.as_ref().unwrap();
        for i in 0..n {
            for j in 0..n {
                let scale = (expected[(i, i)] * expected[(j, j)]).sqrt();
                assert!(
                    (covariance[(i, j)] - expected[(i, j)]).abs() <= 1e-8 * scale,
                    "leg {l} ({i}, {j})"
                );
            }
            let std = estimate.parameters[i].std.unwrap();
            assert!((std * std - expected[(i, i)]).abs() <= 1e-8 * expected[(i, i)]);
        }
        // Residuals: measured minus predicted, with the CSV line of each block.
        assert_eq!(estimate.residuals.len(), m);
        for (row, block) in estimate.residuals.iter().zip(problem.blocks()) {
            assert_eq!(row.line, block.line);
            assert!(row.line.is_some());
        }
        for (k, row) in estimate.residuals.iter().enumerate() {
            assert!((row.residual + r[k]).abs() <= 1e-15);
        }
    }
}

fn legwise(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs")
}

#[test]
fn cli_both_strategies_write_the_divide_and_conquer_result_and_evaluate_improves() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let (out, json, held_out) = (path("cal.yaml"), path("report.json"), path("held.csv"));
    let run = |args: &[&str]| {
        let output = legwise(args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.code(), Some(0), "{args:?}: {stderr}");
        assert_eq!(stderr, "", "no progress bar when stderr is not a terminal");
        String::from_utf8_lossy(&output.stdout).into_owned()
    };
    let stdout = run(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--poses",
        "random",
        "--strategy",
        "both",
        "--calibrated",
        &out,
        "--json",
        &json,
        "--map",
        "0.1",
    ]);
    assert!(stdout.contains("calibrated model (divide and conquer result) written to"));
    assert!(stdout.contains("before (nominal model): position error RMS"));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("this is the divide and conquer result"),
        "{text}"
    );
    assert!(text.contains("urdf: cal.urdf"));
    // The simulated real values travel with the calibrated model.
    let calibrated = Mechanism::load(Path::new(&out)).unwrap();
    let real = &calibrated.simulation.as_ref().unwrap().real;
    assert!((real["k1"] - 1.004).abs() < 1e-15 && real.len() == 12);

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["schema_version"], 2);
    let before = &report["accuracy_map_before"];
    assert!(before["position_error_m"]["rms"].as_f64().unwrap() > 5e-3);
    for result in report["results"].as_array().unwrap() {
        let map = &result["accuracy_map"];
        assert_eq!(map["grid_m"], 0.1);
        assert!(map["position_error_m"]["rms"].as_f64().unwrap() < 1e-3);
        for leg in result["legs"].as_array().unwrap() {
            let correlation = leg["correlation"].as_array().unwrap();
            assert_eq!(correlation.len(), 6);
            for (i, row) in correlation.iter().enumerate() {
                assert!((row[i].as_f64().unwrap() - 1.0).abs() < 1e-12);
            }
            assert!(leg["rows"].is_null(), "simulated rows have no CSV line");
        }
    }

    // Held out: other random poses of the same real robot (another seed only moves the poses,
    // the real values being explicit for the 5R).
    run(&[
        "simulate",
        "--model",
        "models/5r.yaml",
        "--poses",
        "random",
        "--seed",
        "5",
        "--out",
        &held_out,
    ]);
    let stdout = run(&[
        "evaluate",
        "--model",
        &out,
        "--measurements",
        &held_out,
        "--against",
        "models/5r.yaml",
    ]);
    let rms_line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("RMS"))
        .unwrap();
    let values: Vec<f64> = rms_line
        .split_whitespace()
        .skip(1)
        .take(2)
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        values[0] * 10.0 < values[1],
        "calibrated vs nominal (mm): {rms_line}"
    );
}

#[test]
fn row_residuals_of_a_robust_fit_are_the_unweighted_reading_residuals() {
    use legwise::identify::estimate::{identify_with, FitOptions};
    use legwise::identify::robust::RobustLoss;
    use legwise::kinematics::inverse::predict_reading;
    let mechanism = bundled("5r.yaml");
    let data = file::read(&crate_path("tests/data/stats_5r_outlier.csv"), &mechanism).unwrap();
    let options = FitOptions {
        robust: Some(RobustLoss::Cauchy),
        ..Default::default()
    };
    let result = identify_with(
        &mechanism,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        options,
    )
    .unwrap();
    for estimate in &result.legs {
        let l = mechanism.leg_index(&estimate.leg).unwrap();
        let phi: Vec<f64> = estimate.parameters.iter().map(|p| p.estimate).collect();
        assert_eq!(estimate.residuals.len(), data.leg_blocks(l).len());
        for row in &estimate.residuals {
            let (pose, readings) = data
                .rows()
                .find(|(p, _)| p.line == row.line)
                .expect("the residual's CSV line is a row of the file");
            let predicted =
                predict_reading(&mechanism.legs[l], &phi, &pose.pose, &mechanism.home_pose)
                    .unwrap();
            let expected = readings[l].unwrap() - predicted;
            assert!(
                (row.residual - expected).abs() <= 1e-12,
                "line {:?}: {} vs {expected}",
                row.line,
                row.residual
            );
        }
    }
}

/// The README's held-out recipe through a tracker: a calibrated model identified from a
/// measurement file keeps the real mechanism of the model's own simulation, instrument frame
/// included, so held-out data simulated from it (new random poses) come from the mechanism
/// that produced the fit's data. The calibrated model then explains them to well under a
/// millimetre, the nominal one to centimetres; before, the frame was drawn again around the
/// calibrated values (15.8 against 27.8 mm).
#[test]
fn held_out_data_simulated_from_a_calibrated_tracker_model_come_from_the_same_mechanism() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = crate::cli::legwise_succeeds;
    let model = "models/5r-tracker.yaml";
    run(&["simulate", "--model", model, "--out", &path("fit.csv")]);
    run(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &path("fit.csv"),
        "--calibrated",
        &path("cal.yaml"),
    ]);
    run(&[
        "simulate",
        "--model",
        &path("cal.yaml"),
        "--poses",
        "random",
        "--seed",
        "99",
        "--out",
        &path("held.csv"),
    ]);
    let out = run(&[
        "evaluate",
        "--model",
        &path("cal.yaml"),
        "--measurements",
        &path("held.csv"),
        "--against",
        model,
        "--json",
        "-",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rms = |v: &serde_json::Value| v["position_error_m"]["rms"].as_f64().unwrap();
    assert!(rms(&json) < 1e-3, "calibrated: {}", rms(&json));
    assert!(
        rms(&json["against"]) > 10e-3,
        "nominal: {}",
        rms(&json["against"])
    );
    // The frame the fit's data were simulated with, written into the calibrated model.
    let original = Mechanism::load(&crate_path(model)).unwrap();
    let calibrated = Mechanism::load(std::path::Path::new(&path("cal.yaml"))).unwrap();
    let real = |m: &Mechanism| {
        let simulation = m.simulation.as_ref().unwrap();
        legwise::measure::observe_simulate::real_shared(
            m.instrument.as_ref().unwrap(),
            simulation,
            simulation.seed,
        )
    };
    assert_eq!(real(&calibrated), real(&original));
    // The terminal's header keeps the two names apart.
    let text = run(&[
        "evaluate",
        "--model",
        &path("cal.yaml"),
        "--measurements",
        &path("held.csv"),
        "--against",
        model,
    ]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("cal.yaml vs 5r-tracker.yaml"));
}
