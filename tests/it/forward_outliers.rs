//! One bad row of a fit through an instrument — a touch's height, a distance, a measured pose —
//! is named by its line, `--drop-outliers` drops exactly its row and the refit passes
//! (docs/statistics.md §3; identify/shared_outliers.rs).

use serde_json::Value;

use crate::cli::{legwise, text};

/// Simulates `model`'s measurements into a scratch directory, adds `delta` to column `column`
/// of the `which`-th row that has a value there, and returns the directory, the bad file and
/// the bad line (1-based, counting the header).
fn corrupted(
    model: &str,
    column: &str,
    which: usize,
    delta: f64,
) -> (tempfile::TempDir, String, usize) {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean.csv");
    let out = legwise(&[
        "simulate",
        "--model",
        model,
        "--out",
        clean.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let content = std::fs::read_to_string(&clean).unwrap();
    let mut lines: Vec<String> = content.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let at = header
        .iter()
        .position(|h| *h == column)
        .expect("the column");
    let line = (1..lines.len())
        .filter(|&k| !lines[k].split(',').nth(at).unwrap_or_default().is_empty())
        .nth(which)
        .expect("a row with the column");
    let mut cells: Vec<String> = lines[line].split(',').map(String::from).collect();
    cells[at] = (cells[at].parse::<f64>().unwrap() + delta).to_string();
    lines[line] = cells.join(",");
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    (dir, bad.to_str().unwrap().to_string(), line + 1)
}

/// `identify --json -` of `model` on `file` with `extra` options: the exit code and the JSON.
fn identified(model: &str, file: &str, extra: &[&str]) -> (Option<i32>, Value) {
    let mut args = vec![
        "identify",
        "--model",
        model,
        "--measurements",
        file,
        "--json",
        "-",
    ];
    args.extend(extra);
    let out = legwise(&args);
    (
        out.status.code(),
        serde_json::from_slice(&out.stdout).expect("JSON"),
    )
}

/// The lines of the instrument's `key` list (outliers or dropped) of the first result.
fn lines(json: &Value, key: &str) -> Vec<u64> {
    json["results"][0]["instrument"][key]
        .as_array()
        .expect("a list")
        .iter()
        .map(|o| o["line"].as_u64().expect("a line"))
        .collect()
}

#[test]
fn a_bad_touch_distance_or_measured_pose_is_named_and_dropped() {
    let cases = [
        ("models/delta-probe.yaml", "z.nozzle", 9, 0.005),
        ("models/delta-probe-distances.yaml", "distance", 3, 0.005),
        ("models/delta-probe-poses.yaml", "x", 2, 0.005),
    ];
    for (model, column, which, delta) in cases {
        let (_dir, bad, line) = corrupted(model, column, which, delta);
        let (code, json) = identified(model, &bad, &[]);
        assert_eq!(code, Some(3), "{model}: the noise test rejects");
        let flagged = lines(&json, "outliers");
        assert!(!flagged.is_empty(), "{model}");
        assert!(
            flagged.iter().all(|&l| l == line as u64),
            "{model}: {flagged:?} vs {line}"
        );
        let warnings = json["results"][0]["warnings"].to_string();
        assert!(
            warnings.contains(&format!("outlier line {line}, ")),
            "{model}: {warnings}"
        );
        // The wrong advice (more touches) is not given for a row that is bad.
        assert!(
            !warnings.contains("touches at a second height"),
            "{model}: {warnings}"
        );
        let (code, json) = identified(model, &bad, &["--drop-outliers"]);
        assert_eq!(
            code,
            Some(0),
            "{model}: the refit without the row passes: {json}"
        );
        let dropped = lines(&json, "dropped");
        assert!(
            !dropped.is_empty() && dropped.iter().all(|&l| l == line as u64),
            "{model}"
        );
        assert_eq!(lines(&json, "outliers"), Vec::<u64>::new(), "{model}");
        let test = &json["results"][0]["instrument"]["noise_test"];
        assert_eq!(test["rejected"], false, "{model}");
        assert!(test["excluded_rows"].as_u64().unwrap() >= 1, "{model}");
    }
}

#[test]
fn clean_data_flag_nothing_and_drop_nothing() {
    for model in [
        "models/delta-probe.yaml",
        "models/delta-probe-distances.yaml",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let clean = dir.path().join("clean.csv");
        let clean = clean.to_str().unwrap();
        let out = legwise(&["simulate", "--model", model, "--out", clean]);
        assert_eq!(out.status.code(), Some(0));
        let (code, plain) = identified(model, clean, &[]);
        assert_eq!(code, Some(0), "{model}");
        assert!(lines(&plain, "outliers").is_empty(), "{model}");
        let threshold = plain["results"][0]["instrument"]["outlier_threshold"].as_f64();
        assert!(threshold.is_some_and(|t| t > 3.0), "{model}");
        let (code, dropping) = identified(model, clean, &["--drop-outliers"]);
        assert_eq!(code, Some(0), "{model}");
        assert!(lines(&dropping, "dropped").is_empty(), "{model}");
        // Nothing dropped: the same fit.
        let first = |j: &Value| j["results"][0]["legs"][0]["parameters"].to_string();
        assert_eq!(first(&plain), first(&dropping), "{model}");
    }
}

/// The instrument's identified parameters and every leg's: name → (estimate, σ).
fn estimates(json: &Value) -> Vec<(String, f64, f64)> {
    let result = &json["results"][0];
    let legs = result["legs"].as_array().unwrap().iter();
    let parameters = legs
        .flat_map(|l| l["parameters"].as_array().unwrap().iter())
        .chain(result["instrument"]["parameters"].as_array().unwrap());
    parameters
        .filter_map(|p| {
            let std = p["std"].as_f64()?;
            Some((
                p["name"].as_str().unwrap().to_string(),
                p["identified"].as_f64().unwrap(),
                std,
            ))
        })
        .collect()
}

/// A robust (Cauchy) joint fit through an instrument weighs a bad touch, distance, measured
/// pose or tracker row down: the row is named, the noise test passes on the other rows, and
/// the estimate is the refit without the row's to a fraction of its σ, with σ larger by the
/// loss's variance factor (√1.0526 ≈ 1.026 for Cauchy, to the few percent its different
/// weights make).
#[test]
fn a_robust_loss_weighs_a_bad_row_of_every_kind_down() {
    let cases = [
        ("models/delta-probe.yaml", "z.nozzle", 9),
        ("models/delta-probe-distances.yaml", "distance", 3),
        ("models/delta-probe-poses.yaml", "x", 2),
        ("models/5r-tracker.yaml", "x.reflector", 4),
    ];
    for (model, column, which) in cases {
        let (_dir, bad, line) = corrupted(model, column, which, 0.005);
        let (code, dropped) = identified(model, &bad, &["--drop-outliers"]);
        assert_eq!(code, Some(0), "{model}: {dropped}");
        let (code, robust) = identified(model, &bad, &["--robust", "cauchy"]);
        assert_eq!(code, Some(0), "{model}: {robust}");
        assert_eq!(robust["results"][0]["robust"], "cauchy", "{model}");
        let flagged = lines(&robust, "outliers");
        assert!(
            !flagged.is_empty() && flagged.iter().all(|&l| l == line as u64),
            "{model}: {flagged:?} vs {line}"
        );
        let warnings = robust["results"][0]["warnings"].to_string();
        assert!(
            warnings.contains("the cauchy loss weighs it down"),
            "{model}: {warnings}"
        );
        let test = &robust["results"][0]["instrument"]["noise_test"];
        assert_eq!(test["rejected"], false, "{model}");
        assert!(test["excluded_rows"].as_u64().unwrap() >= 1, "{model}");
        let reference = estimates(&dropped);
        let fitted = estimates(&robust);
        assert_eq!(reference.len(), fitted.len(), "{model}");
        for ((name, a, sa), (other, b, sb)) in reference.iter().zip(&fitted) {
            assert_eq!(name, other);
            assert!((a - b).abs() < *sa, "{model}: {name} {b} vs {a} ± {sa}");
            let ratio = sb / sa;
            assert!(
                (1.0..1.1).contains(&ratio),
                "{model}: {name} σ ratio {ratio}"
            );
        }
    }
}

/// `--robust` needs the declared noise through an instrument as in a leg fit, and is one
/// answer to bad rows, `--drop-outliers` the other: both together are refused.
#[test]
fn a_robust_instrument_fit_needs_a_noise_and_refuses_drop_outliers() {
    let both = legwise(&[
        "identify",
        "--model",
        "models/delta-probe.yaml",
        "--robust",
        "huber",
        "--drop-outliers",
    ]);
    assert_eq!(both.status.code(), Some(2));
    let message = text(&both.stderr);
    assert!(
        message.contains("--robust") && message.contains("--drop-outliers"),
        "{message}"
    );
    let dir = tempfile::tempdir().unwrap();
    let model = std::fs::read_to_string("models/delta-probe.yaml").unwrap();
    let urdf = std::fs::canonicalize("models/delta.urdf").unwrap();
    let silent = model
        .replace("noise: {z: 1.0e-5, readings: 0.0}\n", "")
        .replace("urdf: delta.urdf", &format!("urdf: {}", urdf.display()));
    assert!(!silent.contains("\nnoise:"), "the copy declares no noise");
    let copy = dir.path().join("silent.yaml");
    std::fs::write(&copy, silent).unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        copy.to_str().unwrap(),
        "--robust",
        "cauchy",
    ]);
    let message = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{message}");
    assert!(message.contains("noise"), "{message}");
}
