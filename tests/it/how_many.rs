//! `legwise how-many`: the predicted σ over the workspace by number of selected rows; at the
//! model's own count it is what `legwise identify` predicts; bad input is refused by name.
use crate::cli::{assert_fails_with, legwise_succeeds, text};

fn json_of(args: &[&str]) -> serde_json::Value {
    serde_json::from_slice(&legwise_succeeds(args).stdout).unwrap()
}

#[test]
fn at_the_models_own_count_it_is_what_identify_predicts() {
    let model = "models/delta-probe.yaml";
    let identify = json_of(&["identify", "--model", model, "--json", "-"]);
    let expected = &identify["results"][0]["instrument"]["predicted_position"];
    let table = json_of(&[
        "how-many", "--model", model, "--counts", "9,37", "--json", "-",
    ]);
    let at = |k: usize, key: &str| table[k]["predicted"][key].as_f64().unwrap();
    assert_eq!(table[1]["count"], 37);
    for key in ["rms_m", "max_m"] {
        let want = expected[key].as_f64().unwrap();
        assert!(
            (at(1, key) - want).abs() <= 1e-12 * want,
            "{key}: {} vs {want}",
            at(1, key)
        );
    }
    // A quarter of the rows: a larger σ (about twice, as 1/√N).
    assert!(at(0, "rms_m") > 1.5 * at(1, "rms_m"), "{table}");
}

#[test]
fn the_design_sigma_falls_with_the_rows_and_is_identifys_below_twelve_dof() {
    let table = json_of(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "9,18,27,37,49",
        "--json",
        "-",
    ]);
    let design: Vec<f64> = (0..5)
        .map(|k| table[k]["design"]["rms_m"].as_f64().unwrap())
        .collect();
    assert!(design.windows(2).all(|w| w[1] < w[0]), "{design:?}");
    // 9 touches, 6 unknowns: 3 residual degrees of freedom, so identify's σ are the declared
    // noise's too (docs/statistics.md, "Few degrees of freedom").
    let identify = table[0]["predicted"]["rms_m"].as_f64().unwrap();
    assert!(
        (design[0] - identify).abs() <= 1e-6 * identify,
        "{} vs {identify}",
        design[0]
    );
}

#[test]
fn counts_beyond_the_candidates_say_why_and_bad_input_is_refused() {
    let out = legwise_succeeds(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "60",
    ]);
    assert!(
        text(&out.stdout).contains("60 poses requested but the pool has only 49 candidates"),
        "{}",
        text(&out.stdout)
    );
    assert_fails_with(
        &[
            "how-many",
            "--model",
            "models/delta-probe.yaml",
            "--counts",
            "0",
        ],
        "legwise: --counts: expected between 1 and 100000, found 0",
    );
    assert_fails_with(
        &["how-many", "--model", "models/5r.yaml"],
        "legwise: models/5r.yaml: field `instrument.kinematics`: the predicted σ over the workspace is a forward fit's: expected a model seen through the forward kinematics (`instrument.kinematics: forward`), found none",
    );
}

#[test]
fn the_curve_has_a_marker_per_count_and_series() {
    let dir = tempfile::tempdir().unwrap();
    let plots = dir.path().join("pictures");
    legwise_succeeds(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "9,18,37",
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(plots.join("how-many.svg")).unwrap();
    // Three counts, three series (the design's RMS and max, identify's RMS).
    assert_eq!(svg.matches("<circle").count(), 9);
    assert!(svg.contains("design σ, RMS") && svg.contains("identify&apos;s σ, RMS"));
}
