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
