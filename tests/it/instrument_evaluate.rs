//! `legwise evaluate` through an instrument: a calibrated model (written by `identify
//! --calibrated`, its instrument block at the identified frame and offsets) and the nominal one
//! on a held-out file of target coordinates and readings. Every reported error is recomputed
//! here: forward kinematics in closed form for the 5R (checked by the leg's closed-form inverse
//! kinematics for the 3-RPR), the instrument's view of each target in closed form.
use std::path::Path;

use legwise::kinematics::platform::forward;
use legwise::model::Mechanism;
use serde_json::Value;

use crate::accuracy_map::five_bar_fk;
use crate::cli::{legwise, text};

/// One row of an instrument measurement file: leg label, target coordinates, readings.
struct Row {
    line: usize,
    observed: Vec<f64>,
    readings: Vec<Option<f64>>,
}

fn read_rows(csv: &Path, targets: usize) -> Vec<Row> {
    let body = std::fs::read_to_string(csv).unwrap();
    body.lines()
        .enumerate()
        .skip(1)
        .map(|(i, line)| {
            let cells: Vec<&str> = line.split(',').collect();
            let value = |c: &str| (!c.is_empty()).then(|| c.parse::<f64>().unwrap());
            Row {
                line: i + 1,
                observed: cells[1..1 + targets]
                    .iter()
                    .map(|c| value(c).unwrap())
                    .collect(),
                readings: cells[1 + targets..].iter().map(|c| value(c)).collect(),
            }
        })
        .collect()
}

/// The value of the parameter called `name` in `mechanism` (a leg's or the instrument's).
fn value(mechanism: &Mechanism, name: &str) -> f64 {
    let instrument = mechanism.instrument.as_ref().unwrap();
    instrument
        .parameters
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.nominal)
        .or_else(|| {
            mechanism
                .legs
                .iter()
                .flat_map(|l| &l.params)
                .find(|p| p.name == name)
                .map(|p| p.nominal)
        })
        .unwrap_or_else(|| panic!("no parameter `{name}`"))
}

/// Where the instrument (frame `f`, yaw `theta`) sees a target at offset `t` on a platform at
/// `(p, psi)`: `R(θ)ᵀ (p + R(ψ) t − f)`, written out.
fn seen(frame: [f64; 3], offset: [f64; 2], p: [f64; 2], psi: f64) -> [f64; 2] {
    let q = [
        p[0] + psi.cos() * offset[0] - psi.sin() * offset[1] - frame[0],
        p[1] + psi.sin() * offset[0] + psi.cos() * offset[1] - frame[1],
    ];
    let (s, c) = frame[2].sin_cos();
    [c * q[0] + s * q[1], -s * q[0] + c * q[1]]
}

fn frame_of(mechanism: &Mechanism) -> [f64; 3] {
    ["frame_x", "frame_y", "frame_yaw"].map(|n| value(mechanism, n))
}

/// Identifies `model` without noise into a calibrated model, simulates a held-out file from it
/// (its `simulation.real`: the same real mechanism) with another seed and random poses, and
/// evaluates the calibrated model against the nominal one. Returns the directory, the
/// calibrated model's path, the held-out file and the JSON evaluation.
fn calibrated_and_held_out(
    model: &str,
) -> (
    tempfile::TempDir,
    std::path::PathBuf,
    std::path::PathBuf,
    Value,
) {
    let directory = tempfile::tempdir().unwrap();
    let calibrated = directory.path().join("calibrated.yaml");
    let held_out = directory.path().join("held-out.csv");
    let json = directory.path().join("evaluation.json");
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let runs: [Vec<String>; 3] = [
        vec![
            "identify".into(),
            "--model".into(),
            model.into(),
            "--noise-scale".into(),
            "0".into(),
            "--calibrated".into(),
            path(&calibrated),
        ],
        vec![
            "simulate".into(),
            "--model".into(),
            path(&calibrated),
            "--seed".into(),
            "99".into(),
            "--poses".into(),
            "random".into(),
            "--noise-scale".into(),
            "0".into(),
            "--out".into(),
            path(&held_out),
        ],
        vec![
            "evaluate".into(),
            "--model".into(),
            path(&calibrated),
            "--against".into(),
            model.into(),
            "--measurements".into(),
            path(&held_out),
            "--json".into(),
            path(&json),
        ],
    ];
    for args in &runs {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = legwise(&args);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{args:?}: {}",
            text(&out.stderr)
        );
    }
    let stdout = text(
        &legwise(&[
            "evaluate",
            "--model",
            &path(&calibrated),
            "--against",
            model,
            "--measurements",
            &path(&held_out),
        ])
        .stdout,
    );
    assert!(stdout.contains("target position error"), "{stdout}");
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (directory, calibrated, held_out, report)
}

/// The reported per-row errors of one evaluation, by (line, target name).
fn row_errors(evaluation: &Value) -> Vec<(usize, String, f64)> {
    evaluation["row_errors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["line"].as_u64().unwrap() as usize,
                r["target"].as_str().unwrap().to_string(),
                r["position_error_m"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// Checks the reported errors of `evaluation` (model `mechanism`) against `expected` per
/// (line, target), and the summary's RMS and max.
fn assert_errors(evaluation: &Value, expected: &[(usize, String, f64)], what: &str) {
    let reported = row_errors(evaluation);
    assert_eq!(reported.len(), expected.len(), "{what}");
    for (r, e) in reported.iter().zip(expected) {
        assert_eq!((r.0, &r.1), (e.0, &e.1), "{what}");
        assert!(
            (r.2 - e.2).abs() < 1e-9,
            "{what}: line {} target {}: {} vs {}",
            r.0,
            r.1,
            r.2,
            e.2
        );
    }
    let errors: Vec<f64> = expected.iter().map(|e| e.2).collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let max = errors.iter().fold(0.0f64, |a, &b| a.max(b));
    let stats = &evaluation["position_error_m"];
    assert!(
        (stats["rms"].as_f64().unwrap() - rms).abs() < 1e-9,
        "{what}"
    );
    assert!(
        (stats["max"].as_f64().unwrap() - max).abs() < 1e-9,
        "{what}"
    );
}

#[test]
fn five_bar_target_errors_follow_the_closed_form_and_vanish_for_the_calibrated_model() {
    let model = "models/5r-tracker.yaml";
    let (_dir, calibrated, held_out, report) = calibrated_and_held_out(model);
    let rows = read_rows(&held_out, 2);
    for (evaluation, path) in [
        (&report, calibrated.as_path()),
        (&report["against"], Path::new(model)),
    ] {
        let mechanism = Mechanism::load(path).unwrap();
        let phi = mechanism.nominal_parameters();
        let frame = frame_of(&mechanism);
        let offset = [value(&mechanism, "target_x"), value(&mechanism, "target_y")];
        let expected: Vec<(usize, String, f64)> = rows
            .iter()
            .filter(|r| r.readings.iter().all(Option::is_some))
            .map(|r| {
                let readings = [r.readings[0].unwrap(), r.readings[1].unwrap()];
                let p = five_bar_fk(&phi, readings).expect("assembles");
                let m = seen(frame, offset, p, 0.0);
                let error = (m[0] - r.observed[0]).hypot(m[1] - r.observed[1]);
                (r.line, "reflector".to_string(), error)
            })
            .collect();
        assert_eq!(expected.len(), 18, "the shared rows hold both readings");
        assert_errors(evaluation, &expected, &path.display().to_string());
    }
    let calibrated_max = report["position_error_m"]["max"].as_f64().unwrap();
    let nominal_rms = report["against"]["position_error_m"]["rms"]
        .as_f64()
        .unwrap();
    assert!(calibrated_max <= 1e-9, "calibrated: {calibrated_max} m");
    assert!(
        nominal_rms > 1e-3 && nominal_rms < 0.1,
        "nominal: {nominal_rms} m"
    );
    for leg in ["leg1", "leg2"] {
        let max = report["reading_residual"][leg]["max"].as_f64().unwrap();
        assert!(max <= 1e-9, "{leg}: reading residual {max}");
        assert!(
            report["against"]["reading_residual"][leg]["max"]
                .as_f64()
                .unwrap()
                > 1e-4
        );
    }
    assert_eq!(report["targets"][0]["name"], "reflector");
}

#[test]
fn three_rpr_target_errors_follow_forward_kinematics_checked_in_closed_form() {
    let model = "models/3rpr-tracker.yaml";
    let (_dir, calibrated, held_out, report) = calibrated_and_held_out(model);
    let rows = read_rows(&held_out, 4);
    for (evaluation, path) in [
        (&report, calibrated.as_path()),
        (&report["against"], Path::new(model)),
    ] {
        let mechanism = Mechanism::load(path).unwrap();
        let phi = mechanism.nominal_parameters();
        let frame = frame_of(&mechanism);
        let offsets = ["r1", "r2"].map(|t| {
            [
                value(&mechanism, &format!("target_x_{t}")),
                value(&mechanism, &format!("target_y_{t}")),
            ]
        });
        let mut expected = Vec::new();
        for r in rows
            .iter()
            .filter(|r| r.readings.iter().all(Option::is_some))
        {
            let readings: Vec<f64> = r.readings.iter().flatten().copied().collect();
            let pose = forward(&mechanism, &phi, &readings).expect("assembles");
            let (p, psi) = ([pose[0], pose[1]], pose[5]);
            // The pose reproduces every reading by the leg's closed-form inverse kinematics:
            // ρ = |p + R(ψ) b − a|, reading (ρ − ρ0)/k.
            for i in 1..=3 {
                let v = |n: &str| value(&mechanism, n);
                let (a, b) = (
                    [v(&format!("a{i}x")), v(&format!("a{i}y"))],
                    [v(&format!("b{i}x")), v(&format!("b{i}y"))],
                );
                let tip = [
                    p[0] + psi.cos() * b[0] - psi.sin() * b[1] - a[0],
                    p[1] + psi.sin() * b[0] + psi.cos() * b[1] - a[1],
                ];
                let rho = tip[0].hypot(tip[1]);
                let reading = (rho - v(&format!("rho0_{i}"))) / v(&format!("k{i}"));
                assert!(
                    (reading - readings[i - 1]).abs() < 1e-10,
                    "line {} leg {i}",
                    r.line
                );
            }
            for (k, name) in ["r1", "r2"].iter().enumerate() {
                let m = seen(frame, offsets[k], p, psi);
                let error = (m[0] - r.observed[2 * k]).hypot(m[1] - r.observed[2 * k + 1]);
                expected.push((r.line, name.to_string(), error));
            }
        }
        assert_eq!(expected.len(), 2 * 18);
        assert_errors(evaluation, &expected, &path.display().to_string());
        // Per target, the summary of its own rows.
        for (k, name) in ["r1", "r2"].iter().enumerate() {
            let own: Vec<f64> = expected
                .iter()
                .filter(|e| e.1 == *name)
                .map(|e| e.2)
                .collect();
            let max = own.iter().fold(0.0f64, |a, &b| a.max(b));
            let target = &evaluation["targets"][k];
            assert_eq!(target["name"], *name);
            assert!((target["position_error_m"]["max"].as_f64().unwrap() - max).abs() < 1e-9);
        }
    }
    let calibrated_max = report["position_error_m"]["max"].as_f64().unwrap();
    let nominal_rms = report["against"]["position_error_m"]["rms"]
        .as_f64()
        .unwrap();
    assert!(calibrated_max <= 1e-9, "calibrated: {calibrated_max} m");
    assert!(
        nominal_rms > 1e-3 && nominal_rms < 0.1,
        "nominal: {nominal_rms} m"
    );
    assert!(
        report["orientation_error_rad"].is_null(),
        "position targets only"
    );
}

#[test]
fn models_that_read_different_files_are_refused_side_by_side() {
    let directory = tempfile::tempdir().unwrap();
    let csv = directory.path().join("f.csv");
    std::fs::write(&csv, "leg,x.reflector,y.reflector,A1,A2\n,0,1,0,0\n").unwrap();
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/5r-tracker.yaml",
        "--against",
        "models/5r.yaml",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--against models/5r.yaml: its measurements are platform poses")
            && stderr
                .contains("target coordinates through its instrument (x.reflector, y.reflector)"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
    // A file whose rows each hold one reading gives no forward kinematics: refused, named.
    std::fs::write(&csv, "leg,x.reflector,y.reflector,A1,A2\nleg1,0,1,0,\n").unwrap();
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/5r-tracker.yaml",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("no row holds every actuator reading (A1, A2)"),
        "{stderr}"
    );
}

#[test]
fn a_camera_marker_adds_the_orientation_error_of_the_target() {
    use legwise::evaluate::through_instrument::evaluate_observed;
    use legwise::measure::observe_simulate::simulate_observed;
    use legwise::measure::simulate::SimulationOptions;
    let text = std::fs::read_to_string(crate::support::crate_path("models/3rpr-tracker.yaml"))
        .unwrap()
        .replace(
            "    - {name: r1, offset: [0.08, 0.03], measures: position, perturbation: 0.002}\n",
            "    - {name: marker, offset: [0.05, -0.02], measures: pose, perturbation: 0.002}\n",
        )
        .replace(
            "    - {name: r2, offset: [-0.07, 0.03], measures: position, identify: [y], perturbation: 0.002}\n",
            "",
        );
    let urdf = std::fs::read_to_string(crate::support::crate_path("models/3rpr.urdf")).unwrap();
    let mechanism = Mechanism::parse(
        &text,
        Path::new("camera.yaml"),
        &urdf,
        Path::new("3rpr.urdf"),
    )
    .unwrap();
    let options = SimulationOptions {
        noise_scale: 0.0,
        ..Default::default()
    };
    let experiment = simulate_observed(&mechanism, options).unwrap();
    // The real mechanism as a model: its errors vanish.
    let real = mechanism.edited(|real| {
        for (leg, phi) in real.legs.iter_mut().zip(&experiment.real) {
            for (p, &v) in leg.params.iter_mut().zip(phi) {
                p.nominal = v;
            }
        }
        let instrument = real.instrument.as_mut().unwrap();
        for (p, &v) in instrument
            .parameters
            .iter_mut()
            .zip(&experiment.real_shared)
        {
            p.nominal = v;
        }
    });
    let exact = evaluate_observed(&real, &experiment.observations).unwrap();
    assert!(exact.position_error.unwrap().max <= 1e-9);
    assert!(exact.orientation_error.unwrap().max <= 1e-9);
    // The nominal model: the marker's position and orientation errors, recomputed.
    let nominal = evaluate_observed(&mechanism, &experiment.observations).unwrap();
    let phi = mechanism.nominal_parameters();
    let frame = frame_of(&mechanism);
    let offset = [value(&mechanism, "target_x"), value(&mechanism, "target_y")];
    let full: Vec<_> = experiment
        .observations
        .rows
        .iter()
        .filter(|r| r.readings.iter().all(Option::is_some))
        .collect();
    assert_eq!(nominal.row_errors.len(), full.len());
    for (row, reported) in full.iter().zip(&nominal.row_errors) {
        let readings: Vec<f64> = row.readings.iter().flatten().copied().collect();
        let pose = forward(&mechanism, &phi, &readings).unwrap();
        let m = seen(frame, offset, [pose[0], pose[1]], pose[5]);
        let position = (m[0] - row.observed[0]).hypot(m[1] - row.observed[1]);
        let yaw = pose[5] - frame[2] - row.observed[2];
        let orientation = yaw.sin().atan2(yaw.cos()).abs();
        assert_eq!(reported.target, Some(0));
        assert!((reported.position_error.unwrap() - position).abs() < 1e-12);
        assert!((reported.orientation_error.unwrap() - orientation).abs() < 1e-12);
        assert!(
            orientation > 1e-5,
            "the nominal frame is off: {orientation}"
        );
    }
    assert_eq!(nominal.targets.len(), 1);
    assert!(nominal.targets[0].orientation_error.is_some());
}
