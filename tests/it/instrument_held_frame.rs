//! The likelihood-ratio test of a held instrument frame: the drop of χ² when the held frame
//! components are freed, recomputed here from two separate identifications of the same file,
//! and its p-value from the closed form of the χ² law with 3 degrees of freedom.
use std::path::Path;

use serde_json::Value;

use crate::cli::legwise;
use crate::support::crate_path;

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The 3-RPR tracker model, its frame held (`identify: []`) and, if `real` is given, the real
/// frame set to it in the simulation; written into `directory` under `name`.
fn held_model(directory: &Path, name: &str, real: Option<&str>) -> String {
    let urdf = crate_path("models/3rpr.urdf");
    let mut model = std::fs::read_to_string(crate_path("models/3rpr-tracker.yaml"))
        .unwrap()
        .replace(
            "    perturbation: {length: 0.005, angle: 0.005}",
            "    identify: []",
        )
        .replace("urdf: 3rpr.urdf", &format!("urdf: {}", urdf.display()));
    if let Some(real) = real {
        model = model.replace(
            "  poses_per_leg: 18",
            &format!("  real: {real}\n  poses_per_leg: 18"),
        );
    }
    let path = directory.join(name);
    std::fs::write(&path, model).unwrap();
    path.display().to_string()
}

/// P(χ²₃ > x) = erfc(√(x/2)) + √(2x/π) e^(−x/2).
fn chi_squared_3_tail(x: f64) -> f64 {
    statrs::function::erf::erfc((x / 2.0).sqrt())
        + (2.0 * x / std::f64::consts::PI).sqrt() * (-x / 2.0).exp()
}

/// `identify --measurements csv --json -` with `model`: (exit code, the joint result's
/// instrument section, stderr).
fn joint(model: &str, csv: &str) -> (Option<i32>, Value, String) {
    let out = legwise(&[
        "identify",
        "--model",
        model,
        "--measurements",
        csv,
        "--json",
        "-",
    ]);
    let report: Value = serde_json::from_str(&text(&out.stdout)).unwrap();
    (
        out.status.code(),
        report["results"][0]["instrument"].clone(),
        text(&out.stderr),
    )
}

/// Checks the held-frame test of `held` against the freed fit `freed` of the same file (the
/// instrument sections of their joint results).
fn check_against_the_freed_fit(held: &Value, freed: &Value) -> f64 {
    let test = &held["held_frame_test"];
    assert_eq!(
        test["freed"],
        serde_json::json!(["frame_x", "frame_y", "frame_yaw"])
    );
    assert_eq!(test["degrees_of_freedom"], 3);
    let drop = held["noise_test"]["chi_squared"].as_f64().unwrap()
        - freed["noise_test"]["chi_squared"].as_f64().unwrap();
    let reported = test["chi_squared_drop"].as_f64().unwrap();
    assert!(
        (reported - drop).abs() <= 1e-9 * drop.abs().max(1.0),
        "{reported} vs {drop}"
    );
    let p = chi_squared_3_tail(drop.max(0.0));
    let p_reported = test["p_value"].as_f64().unwrap();
    assert!(
        (p_reported - p).abs() <= 1e-9 * p.max(1e-300),
        "{p_reported} vs {p}"
    );
    assert_eq!(test["rejected"], Value::Bool(p < 1e-3));
    for k in 0..3 {
        let estimate = test["estimates"][k].as_f64().unwrap();
        let freed_estimate = freed["parameters"][k]["identified"].as_f64().unwrap();
        assert!(
            (estimate - freed_estimate).abs() < 1e-9,
            "frame component {k}"
        );
    }
    p
}

/// The frame really 5 mm and 5 mrad off and held at its nominal value, on the 18 selected poses
/// per leg of the model's seed: the goodness-of-fit test passes (the legs absorb most of the
/// error), the held-frame test rejects it and the run ends with exit 3 naming the frame.
#[test]
fn a_held_frame_5_mm_and_5_mrad_off_is_rejected_where_the_noise_test_passes() {
    let directory = tempfile::tempdir().unwrap();
    let off = held_model(
        directory.path(),
        "off.yaml",
        Some("{frame_x: 1.505, frame_yaw: 0.305}"),
    );
    let csv = directory.path().join("off.csv").display().to_string();
    let out = legwise(&["simulate", "--model", &off, "--out", &csv]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let (code, held, stderr) = joint(&off, &csv);
    assert_eq!(held["noise_test"]["rejected"], Value::Bool(false));
    let (free_code, freed, _) = joint("models/3rpr-tracker.yaml", &csv);
    assert_eq!(free_code, Some(0));
    assert!(
        freed["held_frame_test"].is_null(),
        "nothing held in the bundled model"
    );
    let p = check_against_the_freed_fit(&held, &freed);
    assert!(p < 1e-3, "p = {p}");
    assert_eq!(code, Some(3), "{stderr}");
    assert!(
        stderr.contains(
            "joint (legs and instrument, Schur complement): the held instrument frame \
             (frame_x, frame_y, frame_yaw) disagrees with the measurements"
        ),
        "{stderr}"
    );
}

/// The frame held at its real value: the drop is a χ²₃ draw, not rejected, exit 0.
#[test]
fn a_frame_held_at_its_real_value_passes_the_held_frame_test() {
    let directory = tempfile::tempdir().unwrap();
    let exact = held_model(directory.path(), "exact.yaml", None);
    let csv = directory.path().join("exact.csv").display().to_string();
    let out = legwise(&["simulate", "--model", &exact, "--out", &csv]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let (code, held, stderr) = joint(&exact, &csv);
    let (_, freed, _) = joint("models/3rpr-tracker.yaml", &csv);
    let p = check_against_the_freed_fit(&held, &freed);
    assert!(p > 1e-3, "p = {p}");
    assert_eq!(code, Some(0), "{stderr}");
}
