//! `evaluate`: forward kinematics from the readings against the measured poses, and each leg's
//! reading residuals. FK and IK must agree on noise-free data with the real model; bad files are
//! refused with exit code 2.
use std::process::Command;

use legwise::evaluate::held_out::evaluate;
use legwise::measure::file;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use serde_json::Value;

use crate::support::{bundled, crate_path};

/// `mechanism` with its nominal parameters replaced by `values` (the "real" model).
fn with_parameters(mechanism: &Mechanism, values: &[Vec<f64>]) -> Mechanism {
    mechanism.edited(|parts| {
        for (leg, phi) in parts.legs.iter_mut().zip(values) {
            for (param, &value) in leg.params.iter_mut().zip(phi) {
                param.nominal = value;
            }
        }
    })
}

#[test]
fn forward_and_inverse_kinematics_agree_on_noise_free_rows_with_the_real_model() {
    for name in ["5r.yaml", "3rpr.yaml"] {
        let mechanism = bundled(name);
        let noise_free = SimulationOptions {
            noise_scale: 0.0,
            ..Default::default()
        };
        let experiment = simulate(&mechanism, noise_free).unwrap();
        let real_model = with_parameters(&mechanism, &experiment.real);
        let evaluation = evaluate(&real_model, &experiment.measurements).unwrap();
        // Only the shared rows hold every reading; the divide-and-conquer rows hold one each.
        assert_eq!(
            evaluation.row_errors.len(),
            experiment.measurements.shared_count(),
            "{name}"
        );
        assert!(evaluation.non_assemblable.is_empty(), "{name}");
        for row in &evaluation.row_errors {
            assert!(row.position_error.unwrap() <= 1e-9, "{name}: {row:?}");
            let orientation = row.orientation_error;
            assert_eq!(orientation.is_some(), name == "3rpr.yaml", "{name}");
            assert!(orientation.unwrap_or(0.0) <= 1e-9, "{name}: {row:?}");
        }
        for leg in &evaluation.reading_residual {
            assert!(leg.max.unwrap() <= 1e-12, "{name}: {leg:?}");
            assert!(leg.unreachable.is_empty());
        }
        // The nominal model explains the same rows much worse.
        let nominal = evaluate(&mechanism, &experiment.measurements).unwrap();
        assert!(nominal.position_error.unwrap().rms > 1e-4, "{name}");
    }
}

#[test]
fn rows_the_mechanism_cannot_assemble_at_are_listed_by_csv_line() {
    let mechanism = bundled("5r.yaml");
    // Line 3: both driving links point outwards (elbows 2.5 m apart, distal links 2.2 m long).
    let text = "leg,x,y,A1,A2\n,0.0,1.0956521739,2.2528832243731345,2.2528832243731345\n,0.0,1.0,3.141592653589793,3.141592653589793\n";
    let path = std::path::Path::new("held-out.csv");
    let data = file::parse(text, path, &mechanism).unwrap();
    let evaluation = evaluate(&mechanism, &data).unwrap();
    assert_eq!(evaluation.non_assemblable, vec![3]);
    assert_eq!(evaluation.rows, 2);
    let lines: Vec<usize> = evaluation.row_errors.iter().map(|r| r.line).collect();
    assert_eq!(lines, vec![2, 3]);
    assert!(evaluation.row_errors[0].position_error.is_some());
    // Line 2 holds the exact home readings (the home pose is given to 10 digits).
    assert!(evaluation.position_error.unwrap().max < 1e-9);
}

fn legwise(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs")
}

#[test]
fn a_file_without_a_full_row_exits_2_and_says_so() {
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/five_poses.csv",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("tests/data/five_poses.csv")
            && stderr.contains("no row holds every actuator reading (A1, A2)"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn json_output_may_not_overwrite_an_input() {
    let before = std::fs::read(crate_path("models/5r.urdf")).unwrap();
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/five_poses.csv",
        "--json",
        "models/../models/5r.urdf",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--json would overwrite the URDF"));
    assert_eq!(std::fs::read(crate_path("models/5r.urdf")).unwrap(), before);
}

#[test]
fn the_json_holds_the_documented_keys_for_both_models() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("held-out.csv");
    let json = dir.path().join("evaluation.json");
    let mechanism = bundled("3rpr.yaml");
    let experiment = simulate(&mechanism, SimulationOptions::default()).unwrap();
    file::write(&csv, &mechanism, &experiment.measurements).unwrap();
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/3rpr.yaml",
        "--measurements",
        csv.to_str().unwrap(),
        "--against",
        "models/3rpr.yaml",
        "--json",
        json.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("(mm)") && stdout.contains("(mrad)") && stdout.contains("1.0x"));
    let value: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(value["schema_version"], 2);
    assert_eq!(value["legwise_version"], env!("CARGO_PKG_VERSION"));
    for object in [&value, &value["against"]] {
        for key in ["model", "measurements", "rows", "non_assemblable"] {
            assert!(!object[key].is_null(), "{key}");
        }
        for key in ["position_error_m", "orientation_error_rad"] {
            for stat in ["rms", "median", "p95", "max"] {
                assert!(object[key][stat].as_f64().unwrap() > 0.0, "{key}.{stat}");
            }
        }
        for leg in ["leg1", "leg2", "leg3"] {
            let residual = &object["reading_residual"][leg];
            assert!(residual["rms"].as_f64().unwrap() <= residual["max"].as_f64().unwrap());
        }
        assert_eq!(object["rows"], experiment.measurements.len());
    }
    // The terminal's reading residuals are the JSON's, in millimetres (the 3-RPR's legs are
    // prismatic), one line per leg and statistic.
    for leg in ["leg1", "leg2", "leg3"] {
        for (label, key) in [("RMS", "rms"), ("max", "max")] {
            let value = value["reading_residual"][leg][key].as_f64().unwrap();
            let line = stdout
                .lines()
                .find(|l| l.trim_start().starts_with(&format!("{leg} {label}")))
                .unwrap_or_else(|| panic!("no {leg} {label} line:\n{stdout}"));
            assert!(
                line.contains(&format!("{:.4} mm", 1e3 * value)),
                "{line} against {value}"
            );
        }
    }
}
