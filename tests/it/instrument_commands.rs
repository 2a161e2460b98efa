//! The commands around `identify` on a model with an instrument block: `simulate` writes what
//! the instrument reports (read back by `identify --measurements`), `select` writes the poses
//! to command with the target and reading columns to fill in.
use std::path::Path;

use legwise::measure::observations::to_csv;
use legwise::measure::observe_simulate::{observed_from, simulate_observed, without_pose_noise};
use legwise::measure::simulate::{simulate_at, PoseSets, SimulationOptions};
use legwise::model::Mechanism;
use serde_json::Value;

use crate::cli::{legwise, text};
use crate::support::bundled;

const ZERO_NOISE: SimulationOptions = SimulationOptions {
    seed: None,
    noise_scale: 0.0,
    poses_per_leg: None,
};

/// Runs `identify --measurements csv --json` on `model` and checks that every identified
/// quantity of the joint result equals `real` (legs, model order) and `real_shared` to 1e-9.
fn assert_recovered_through(model: &str, csv: &Path, real: &[Vec<f64>], real_shared: &[f64]) {
    let json = csv.with_extension("json");
    let out = legwise(&[
        "identify",
        "--model",
        model,
        "--measurements",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let mechanism = Mechanism::load(Path::new(model)).unwrap();
    let joint = &report["results"][0];
    assert!(joint["strategy"].as_str().unwrap().starts_with("joint"));
    let instrument = mechanism.instrument.as_ref().unwrap();
    let mut checked = 0;
    for (p, value) in instrument.parameters.iter().zip(real_shared) {
        let entry = joint["instrument"]["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == p.name.as_str())
            .unwrap();
        if p.identified {
            let estimate = entry["identified"].as_f64().unwrap();
            assert!(
                (estimate - value).abs() <= 1e-9,
                "{}: {estimate} vs {value}",
                p.name
            );
            checked += 1;
        }
    }
    for (l, leg) in mechanism.legs.iter().enumerate() {
        let entry = joint["legs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == leg.name.as_str())
            .unwrap();
        for (p, value) in leg.params.iter().zip(&real[l]) {
            if !p.identified {
                continue;
            }
            let found = entry["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .find(|e| e["name"] == p.name.as_str())
                .unwrap();
            let estimate = found["identified"].as_f64().unwrap();
            assert!(
                (estimate - value).abs() <= 1e-9,
                "{}: {estimate} vs {value}",
                p.name
            );
            checked += 1;
        }
    }
    assert!(checked >= 8, "only {checked} quantities checked");
}

#[test]
fn simulate_writes_target_columns_that_identify_reads_back_and_recovers_at_zero_noise() {
    let directory = tempfile::tempdir().unwrap();
    for name in [
        "5r-tracker",
        "3rpr-tracker",
        "delta-tracker",
        "hexapod-tracker",
    ] {
        let model = format!("models/{name}.yaml");
        let csv = directory.path().join(format!("{name}.csv"));
        let out = legwise(&[
            "simulate",
            "--model",
            &model,
            "--poses",
            "random",
            "--noise-scale",
            "0",
            "--out",
            csv.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        // The file is the instrument's report, as the library simulates it for the same seed.
        let mechanism = bundled(&format!("{name}.yaml"));
        let experiment = simulate_observed(&mechanism, ZERO_NOISE).unwrap();
        let expected = to_csv(&mechanism, &experiment.observations).unwrap();
        let written = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(written, expected);
        let header = written.lines().next().unwrap();
        assert!(
            header.contains(",x.") && !header.contains(",x,"),
            "{header}"
        );
        let spatial = mechanism.instrument.as_ref().unwrap().spatial;
        assert_eq!(header.contains(",z."), spatial, "{header}");
        assert_recovered_through(&model, &csv, &experiment.real, &experiment.real_shared);
    }
}

#[test]
fn select_writes_the_poses_to_command_and_the_columns_to_fill_in_which_identify_reads() {
    let directory = tempfile::tempdir().unwrap();
    let template = directory.path().join("poses.csv");
    let model = "models/5r-tracker.yaml";
    let out = legwise(&[
        "select",
        "--model",
        model,
        "--out",
        template.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let written = std::fs::read_to_string(&template).unwrap();
    let mut lines = written.lines();
    assert_eq!(
        lines.next().unwrap(),
        "leg,pose.x,pose.y,x.reflector,y.reflector,A1,A2"
    );
    // Unfilled, identify refuses the first empty target cell, naming it.
    let out = legwise(&[
        "identify",
        "--model",
        model,
        "--measurements",
        template.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("line 2, column `x.reflector`") && stderr.contains("missing value"),
        "{stderr}"
    );
    // Filled in by a simulated instrument at exactly the commanded poses: identify reads it
    // (the pose columns ignored) and recovers the model at zero noise.
    let mechanism = bundled("5r-tracker.yaml");
    let mut sets = PoseSets {
        per_leg: vec![Vec::new(); mechanism.legs.len()],
        shared: Vec::new(),
    };
    let mut rows = Vec::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), 7, "{line}");
        assert!(cells[3..].iter().all(|c| c.is_empty()), "{line}");
        let pose = [
            cells[1].parse().unwrap(),
            cells[2].parse().unwrap(),
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        match mechanism.leg_index(cells[0]) {
            Some(leg) => sets.per_leg[leg].push(pose),
            None => sets.shared.push(pose),
        }
        rows.push((cells[0].to_string(), pose));
    }
    assert!(rows.len() >= 2 * mechanism.legs.len());
    let experiment = simulate_at(&without_pose_noise(&mechanism), &sets, ZERO_NOISE).unwrap();
    let observed = observed_from(&mechanism, experiment, ZERO_NOISE).unwrap();
    let mut filled = String::from("leg,pose.x,pose.y,x.reflector,y.reflector,A1,A2\n");
    for (row, pose) in observed
        .observations
        .rows
        .iter()
        .zip(observed.poses.poses())
    {
        let leg = row.leg.map_or("", |l| mechanism.legs[l].name.as_str());
        assert!(
            rows.contains(&(leg.to_string(), pose.pose)),
            "{:?}",
            pose.pose
        );
        let cell = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v}"));
        filled.push_str(&format!(
            "{leg},{},{},{},{},{},{}\n",
            pose.pose[0],
            pose.pose[1],
            row.observed[0],
            row.observed[1],
            cell(row.readings[0]),
            cell(row.readings[1])
        ));
    }
    let csv = directory.path().join("filled.csv");
    std::fs::write(&csv, filled).unwrap();
    assert_recovered_through(model, &csv, &observed.real, &observed.real_shared);
}
