//! The README's library example (examples/library.rs) on the tracker model's CSV: each result
//! carries its own verdict, by the rules of the run's; the run's verdict is left as it was.
use std::process::Command;

use legwise::{identify, Measurements, Settings, Strategy};
use serde_json::Value;

use crate::support::{bundled, crate_path};

/// The two-stage result on examples/data/5r-tracker.csv rejects the declared noise (gamma1 is
/// 13 mrad off with a σ of 0.28 mrad): its own verdict is false, the joint result's true, and
/// the run's (which judges the joint result only) stays true.
#[test]
fn each_result_of_the_tracker_csv_has_its_own_verdict() {
    let mechanism = bundled("5r-tracker.yaml");
    let data = Measurements::read(&crate_path("examples/data/5r-tracker.csv"), &mechanism)
        .expect("the bundled CSV reads");
    let report = identify(&mechanism, &data, &Settings::default()).expect("identified");
    let [joint, two_stage] = &report.results[..] else {
        panic!("joint, then two-stage: {:?}", report.results.len());
    };
    assert_eq!(joint.strategy, Strategy::Joint);
    assert_eq!(two_stage.strategy, Strategy::TwoStage);
    assert!(report.trusted(), "{:?}", report.trust_issues());
    assert!(
        report.result_trusted(joint),
        "{:?}",
        report.result_trust_issues(joint)
    );
    let issues = report.result_trust_issues(two_stage);
    assert!(!report.result_trusted(two_stage));
    assert!(
        issues
            .iter()
            .any(|i| i.starts_with("two-stage") && i.contains("reject the declared noise")),
        "{issues:?}"
    );

    let json = serde_json::to_value(report.to_json()).unwrap();
    let results = json["results"].as_array().unwrap();
    assert_eq!(results[0]["trusted"], Value::Bool(true));
    assert_eq!(results[0]["trust_issues"], serde_json::json!([]));
    assert_eq!(results[1]["trusted"], Value::Bool(false));
    assert_eq!(results[1]["trust_issues"], serde_json::json!(issues));
}

/// What the example prints: `trusted: false` beside the two-stage result, `trusted: true`
/// beside the joint one (the line CI greps for), and the run's verdict last.
#[test]
fn the_library_example_prints_each_results_verdict() {
    let out = Command::new(env!("CARGO"))
        .args(["run", "--quiet", "--example", "library", "--"])
        .args(["models/5r-tracker.yaml", "examples/data/5r-tracker.csv"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let verdicts: Vec<&str> = stdout.lines().filter(|l| !l.starts_with(' ')).collect();
    assert_eq!(
        verdicts,
        [
            "joint (legs and instrument, Schur complement) (trusted: true)",
            "two-stage (instrument registered first, then D&C) (trusted: false)",
            "run trusted: true",
        ],
        "{stdout}"
    );
}
