//! One JSON schema for every report: a plain and a tracker report read through the same keys,
//! every key of both documented in docs/report.md, and the numbers they carry recomputed from
//! each other (errors from the real values, σ from the covariance).
use std::collections::BTreeSet;

use legwise::{run, Mechanism, Settings};
use serde_json::Value;

use crate::support::bundled;

/// The JSON document of the default simulated run of a bundled model.
fn report(model: &str) -> Value {
    let mechanism: Mechanism = bundled(model);
    let report = run(&mechanism, &Settings::default()).unwrap();
    serde_json::to_value(report.to_json()).unwrap()
}

/// The keys of an object, sorted.
fn keys(value: &Value) -> BTreeSet<&str> {
    value
        .as_object()
        .unwrap_or_else(|| panic!("an object: {value}"))
        .keys()
        .map(String::as_str)
        .collect()
}

fn set(list: &[&'static str]) -> BTreeSet<&'static str> {
    list.iter().copied().collect()
}

const TOP: [&str; 10] = [
    "schema_version",
    "legwise_version",
    "mechanism",
    "model",
    "mode",
    "measurements",
    "units",
    "instrument_columns",
    "results",
    // Written with --map only.
    "accuracy_map_before",
];
const RESULT: [&str; 9] = [
    "strategy",
    "solver",
    "weights",
    "robust",
    "drop_outliers",
    "warnings",
    "instrument",
    "legs",
    "fixed_legs",
];
const LEG: [&str; 22] = [
    "name",
    "measurements",
    "parameters",
    "cost_before",
    "cost_after",
    "residual_sigma",
    "parameter_error_rms_before",
    "parameter_error_rms_after",
    "singular_values",
    "condition_number",
    "scaled_condition_number",
    "observability",
    "warnings",
    "noise_test",
    "outlier_threshold",
    "outliers",
    "dropped",
    "solver",
    "covariance_parameters",
    "covariance",
    "correlation",
    "rows",
];
const PARAMETER: [&str; 9] = [
    "name",
    "unit",
    "fixed",
    "nominal",
    "identified",
    "std",
    "real",
    "error_before",
    "error_after",
];
const INSTRUMENT: [&str; 7] = [
    "parameters",
    "rows",
    "unknowns",
    "rms_residual",
    "noise_test",
    "held_frame_test",
    "observability",
];

/// A parameter's errors are its values minus the real one, bit for bit; a fixed one keeps its
/// nominal value and has no σ.
fn check_parameter(p: &Value) {
    assert_eq!(keys(p), set(&PARAMETER), "{p}");
    let real = p["real"]
        .as_f64()
        .expect("a simulation knows the real value");
    let after = p["identified"].as_f64().unwrap() - real;
    let before = p["nominal"].as_f64().unwrap() - real;
    assert_eq!(
        p["error_after"].as_f64().unwrap().to_bits(),
        after.to_bits()
    );
    assert_eq!(
        p["error_before"].as_f64().unwrap().to_bits(),
        before.to_bits()
    );
    if p["fixed"] == true {
        assert!(p["std"].is_null(), "{p}");
        assert_eq!(p["identified"], p["nominal"], "{p}");
    }
}

/// The plain and the tracker report: the same keys at every level, every parameter with the
/// same keys (the instrument's too), and each identified leg parameter's σ the square root of
/// its covariance diagonal.
#[test]
fn a_plain_and_a_tracker_report_read_through_the_same_documented_keys() {
    for (model, through) in [("5r.yaml", false), ("5r-tracker.yaml", true)] {
        let value = report(model);
        let top: BTreeSet<&str> = set(&TOP[..9]);
        assert_eq!(keys(&value), top, "{model}");
        assert_eq!(value["schema_version"], 2);
        assert_eq!(value["instrument_columns"].is_array(), through, "{model}");
        let results = value["results"].as_array().unwrap();
        assert_eq!(results.len(), if through { 2 } else { 1 });
        for result in results {
            assert_eq!(keys(result), set(&RESULT), "{model}");
            assert_eq!(result["instrument"].is_object(), through, "{model}");
            if through {
                let instrument = &result["instrument"];
                assert_eq!(keys(instrument), set(&INSTRUMENT));
                for p in instrument["parameters"].as_array().unwrap() {
                    check_parameter(p);
                }
            }
            for leg in result["legs"].as_array().unwrap() {
                assert_eq!(keys(leg), set(&LEG), "{model}");
                let names: Vec<&str> = leg["covariance_parameters"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|n| n.as_str().unwrap())
                    .collect();
                let identified: Vec<&Value> = leg["parameters"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter(|p| p["fixed"] == false)
                    .collect();
                assert_eq!(names.len(), identified.len());
                for (k, p) in identified.iter().enumerate() {
                    check_parameter(p);
                    assert_eq!(p["name"].as_str().unwrap(), names[k]);
                    let variance = leg["covariance"][k][k].as_f64().unwrap();
                    let std = p["std"].as_f64().unwrap();
                    assert!(
                        (std - variance.sqrt()).abs() <= 1e-15 * std,
                        "{model}: {} σ {std} vs √{variance}",
                        names[k]
                    );
                }
                for p in leg["parameters"].as_array().unwrap() {
                    check_parameter(p);
                }
            }
        }
    }
}

/// Every key either report writes is documented in docs/report.md (as `key`).
#[test]
fn every_key_of_the_reports_is_documented() {
    let docs = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/report.md"),
    )
    .unwrap();
    fn collect<'v>(value: &'v Value, out: &mut BTreeSet<&'v str>) {
        match value {
            Value::Object(map) => {
                for (key, v) in map {
                    out.insert(key);
                    collect(v, out);
                }
            }
            Value::Array(items) => items.iter().for_each(|v| collect(v, out)),
            _ => {}
        }
    }
    let reports = [report("5r.yaml"), report("5r-tracker.yaml")];
    let mut all = BTreeSet::new();
    for value in &reports {
        collect(value, &mut all);
    }
    // The indices are documented as a range, `O1` … `O5`.
    let undocumented: Vec<&str> = all
        .into_iter()
        .filter(|key| !docs.contains(&format!("`{key}`")) && !matches!(*key, "O2" | "O3" | "O4"))
        .collect();
    assert!(
        undocumented.is_empty(),
        "not in docs/report.md: {undocumented:?}"
    );
}
