//! `identify --map` on a model with an instrument block: the accuracy map compares the
//! identified mechanism with the real (simulated) one exactly as without an instrument (the
//! instrument only measures). Every map point is recomputed with the closed-form 5R: the
//! nominal or identified legs' inverse kinematics command, the real legs' forward kinematics
//! move.
use serde_json::Value;

use crate::accuracy_map::{five_bar_fk, five_bar_ik};
use crate::cli::{legwise, text};

/// Runs `identify` on the 5R tracker model with `--map 0.05 --json -` and `extra`.
fn identify_with_map(extra: &[&str]) -> Value {
    let mut args = vec![
        "identify",
        "--model",
        "models/5r-tracker.yaml",
        "--map",
        "0.05",
        "--json",
        "-",
    ];
    args.extend(extra);
    let out = legwise(&args);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("accuracy map over 0.95") && stderr.contains("after, joint"),
        "{stderr}"
    );
    serde_json::from_str(&text(&out.stdout)).unwrap()
}

/// Per leg, the values under `key` (`identified`, `nominal` or `real`) of every parameter of a
/// result.
fn legs(result: &Value, key: &str) -> Vec<Vec<f64>> {
    result["legs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|leg| {
            leg["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| p[key].as_f64().unwrap())
                .collect()
        })
        .collect()
}

/// Checks every point of `map` against the closed form with `commanding` commanding the `real`
/// legs; returns the RMS of the errors.
fn assert_closed_form(map: &Value, commanding: &[Vec<f64>], real: &[Vec<f64>], what: &str) -> f64 {
    let mut squares = Vec::new();
    for point in map["points"].as_array().unwrap() {
        let pose: Vec<f64> = point["pose"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let (x, y) = (pose[0], pose[1]);
        let reached = five_bar_ik(commanding, x, y).and_then(|r| five_bar_fk(real, r));
        match (reached, point["position_error_m"].as_f64()) {
            (Some(p), Some(error)) => {
                let expected = (p[0] - x).hypot(p[1] - y);
                assert!(
                    (error - expected).abs() < 1e-9,
                    "{what} ({x}, {y}): {error} vs {expected}"
                );
                squares.push(expected * expected);
            }
            (None, None) => {}
            (reached, error) => panic!("{what} ({x}, {y}): closed form {reached:?}, map {error:?}"),
        }
    }
    assert!(squares.len() > 100, "{what}");
    let rms = (squares.iter().sum::<f64>() / squares.len() as f64).sqrt();
    let reported = map["position_error_m"]["rms"].as_f64().unwrap();
    assert!((reported - rms).abs() < 1e-9, "{what}: {reported} vs {rms}");
    rms
}

#[test]
fn the_maps_follow_the_closed_form_and_the_joint_result_vanishes_without_noise() {
    let report = identify_with_map(&["--noise-scale", "0"]);
    let joint = &report["results"][0];
    let real = legs(joint, "real");
    let nominal = legs(joint, "nominal");
    let before = assert_closed_form(&report["accuracy_map_before"], &nominal, &real, "before");
    assert!(before > 5e-3, "the nominal 5R is mm off: {before}");
    let identified = legs(joint, "identified");
    let after = assert_closed_form(&joint["accuracy_map"], &identified, &real, "joint");
    assert!(after < 1e-9, "joint, zero noise: {after}");
    assert!(
        joint["accuracy_map"]["position_error_m"]["max"]
            .as_f64()
            .unwrap()
            < 1e-9
    );
    // The two-stage result: its own legs commanding, checked the same way.
    let two_stage = &report["results"][1];
    assert!(two_stage["strategy"]
        .as_str()
        .unwrap()
        .starts_with("two-stage"));
    assert_closed_form(
        &two_stage["accuracy_map"],
        &legs(two_stage, "identified"),
        &real,
        "two-stage",
    );
}

#[test]
fn with_noise_the_joint_map_is_the_identified_legs_against_the_real_ones() {
    let report = identify_with_map(&[]);
    let joint = &report["results"][0];
    let real = legs(joint, "real");
    let before = assert_closed_form(
        &report["accuracy_map_before"],
        &legs(joint, "nominal"),
        &real,
        "before",
    );
    let after = assert_closed_form(
        &joint["accuracy_map"],
        &legs(joint, "identified"),
        &real,
        "joint",
    );
    assert!(
        after > 1e-6 && after < before / 5.0,
        "before {before}, after {after}"
    );
}

#[test]
fn a_map_from_a_measurement_file_through_an_instrument_is_refused_before_any_work() {
    let directory = tempfile::tempdir().unwrap();
    let csv = directory.path().join("f.csv");
    std::fs::write(&csv, "leg,x.reflector,y.reflector,A1,A2\n,0,1,0,0\n").unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r-tracker.yaml",
        "--measurements",
        csv.to_str().unwrap(),
        "--map",
        "0.05",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    assert!(
        text(&out.stderr).contains("--map: the accuracy map needs the real parameters"),
        "{}",
        text(&out.stderr)
    );
}
