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

const TOP: [&str; 12] = [
    "schema_version",
    "legwise_version",
    "mechanism",
    "model",
    "mode",
    "measurements",
    "units",
    "instrument_columns",
    "trusted",
    "trust_issues",
    "results",
    // Written with --map only.
    "accuracy_map_before",
];
const RESULT: [&str; 12] = [
    "strategy",
    "solver",
    "weights",
    "robust",
    "drop_outliers",
    "warnings",
    "trusted",
    "trust_issues",
    "instrument",
    "legs",
    "fixed_legs",
    "covariance",
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
const PARAMETER: [&str; 11] = [
    "name",
    "unit",
    "fixed",
    "nominal",
    "identified",
    "std",
    "degrees_of_freedom",
    "ci95",
    "real",
    "error_before",
    "error_after",
];
const INSTRUMENT: [&str; 10] = [
    "parameters",
    "rows",
    "unknowns",
    "rms_residual",
    "noise_test",
    "outlier_threshold",
    "outliers",
    "dropped",
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
        let top: BTreeSet<&str> = set(&TOP[..11]);
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

/// Each identified parameter's 95 % interval is its estimate ± t·std, t the 0.975 quantile of
/// Student's t on its degrees of freedom (printed tables: 2.178813 for 12, 2.063899 for 24):
/// the JSON, the terminal's `± 95 %` column and the calibrated model's comments agree.
#[test]
fn intervals_use_student_s_t_on_the_residual_degrees_of_freedom() {
    use legwise::identify::estimate::ParameterEstimate;
    let t = |dof: u64| match dof {
        12 => 2.178_813,
        24 => 2.063_899,
        other => panic!("no printed quantile for {other} degrees of freedom"),
    };
    for (model, dof) in [("5r.yaml", 12), ("5r-tracker.yaml", 24)] {
        let out = crate::cli::legwise(&[
            "identify",
            "--model",
            &format!("models/{model}"),
            "--json",
            "-",
        ]);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}",
            crate::cli::text(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let legs = json["results"][0]["legs"].as_array().unwrap();
        let mut checked = 0;
        for p in legs
            .iter()
            .flat_map(|l| l["parameters"].as_array().unwrap())
        {
            if p["fixed"].as_bool().unwrap() {
                assert!(p["ci95"].is_null() && p["degrees_of_freedom"].is_null());
                continue;
            }
            assert_eq!(
                p["degrees_of_freedom"].as_u64(),
                Some(dof),
                "{model} {}",
                p["name"]
            );
            let (value, std) = (
                p["identified"].as_f64().unwrap(),
                p["std"].as_f64().unwrap(),
            );
            let ci: Vec<f64> = p["ci95"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            for (bound, sign) in ci.iter().zip([-1.0, 1.0]) {
                let expected = value + sign * t(dof) * std;
                assert!(
                    (bound - expected).abs() <= 1e-6 * t(dof) * std,
                    "{model} {}: {bound} vs {expected}",
                    p["name"]
                );
            }
            checked += 1;
        }
        assert!(checked >= 6, "{model}: {checked} intervals");
    }
    // The library's half width, which the terminal and the calibrated model print.
    let p = ParameterEstimate {
        name: "l1".into(),
        unit: legwise::model::params::Unit::Metre,
        nominal: 0.75,
        estimate: 0.75,
        std: Some(1e-3),
        identified: true,
        degrees_of_freedom: Some(12),
        prior: None,
        data_share: None,
    };
    assert!((p.half_width95().unwrap() - 2.178_813e-3).abs() < 1e-9);
    assert_eq!(
        ParameterEstimate {
            std: None,
            ..p.clone()
        }
        .half_width95(),
        None
    );
    // A std without degrees of freedom is the declared noise's (too few to scale by σ̂):
    // the normal quantile.
    let declared = ParameterEstimate {
        degrees_of_freedom: None,
        prior: None,
        data_share: None,
        ..p
    };
    assert!(declared.std_from_declared_noise());
    assert!((declared.half_width95().unwrap() - 1.959_964e-3).abs() < 1e-9);
}
