//! The JSON report (`--json PATH`): the same data as the terminal report. Non-finite numbers
//! are written as `null`, never as NaN.

use serde_json::{json, Value};

use nalgebra::DMatrix;

use super::terminal::all_warnings;
use super::IdentifyReport;
use crate::identify::estimate::{LegEstimate, StrategyResult, Weighting};
use crate::identify::statistics::Outlier;

/// Version of the JSON layout documented in `docs/report.md`; raised when a key changes meaning or
/// disappears (new keys do not change it).
pub const SCHEMA_VERSION: u32 = 1;

/// The keys every legwise JSON document starts with: the schema and the program version.
pub fn header() -> Value {
    json!({
        "schema_version": SCHEMA_VERSION,
        "legwise_version": env!("CARGO_PKG_VERSION"),
    })
}

/// Merges the keys of the object `extra` into the object `value` (later keys win).
pub fn merge(value: &mut Value, extra: Value) {
    if let (Value::Object(target), Value::Object(source)) = (value, extra) {
        target.extend(source);
    }
}

/// A matrix as rows of numbers (non-finite entries as `null`).
pub fn matrix(m: &DMatrix<f64>) -> Value {
    Value::Array(
        m.row_iter()
            .map(|row| Value::Array(row.iter().map(|&v| finite(v)).collect()))
            .collect(),
    )
}

/// The correlation matrix of a covariance matrix: `V_ij / √(V_ii V_jj)`.
pub fn correlation(covariance: &DMatrix<f64>) -> DMatrix<f64> {
    let std = covariance.diagonal().map(f64::sqrt);
    DMatrix::from_fn(covariance.nrows(), covariance.ncols(), |i, j| {
        covariance[(i, j)] / (std[i] * std[j])
    })
}

/// A leg's covariance, correlation and per-row residuals (rows only for measurements from a file).
fn leg_statistics(leg: &LegEstimate) -> Value {
    let names: Vec<&str> = leg
        .parameters
        .iter()
        .filter(|p| p.identified)
        .map(|p| p.name.as_str())
        .collect();
    let from_file = leg.residuals.iter().all(|r| r.line.is_some());
    json!({
        "covariance_parameters": names,
        "covariance": leg.covariance.as_ref().map(matrix),
        "correlation": leg.covariance.as_ref().map(|v| matrix(&correlation(v))),
        "rows": from_file.then(|| leg.residuals.iter().map(|r| json!({
            "line": r.line,
            "residual": finite(r.residual),
        })).collect::<Vec<_>>()),
    })
}

/// A number, or `null` when it is not finite (JSON has no NaN or infinity).
pub fn finite(value: f64) -> Value {
    if value.is_finite() {
        json!(value)
    } else {
        Value::Null
    }
}

/// [`finite`] of an optional number (`None` is `null`).
pub fn optional(value: Option<f64>) -> Value {
    value.map_or(Value::Null, finite)
}

/// The report as a JSON value.
pub fn to_json(report: &IdentifyReport<'_>) -> Value {
    let mut value = header();
    merge(
        &mut value,
        json!({
            "mechanism": report.mechanism.name,
            "model": report.mechanism.model_path.display().to_string(),
            "mode": report.mechanism.mode,
            "measurements": report.source,
            "units": "SI (m, rad); costs are 1/2 ||r||^2 in reading units squared",
            "results": report.results.iter().map(|r| result(report, r)).collect::<Vec<_>>(),
        }),
    );
    value
}

fn result(report: &IdentifyReport<'_>, result: &StrategyResult) -> Value {
    let legs: Vec<Value> = result
        .legs
        .iter()
        .map(|leg| {
            let parameters: Vec<Value> = leg
                .parameters
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let real = report.real_value(&leg.leg, i);
                    json!({
                        "name": p.name,
                        "unit": p.unit.to_string(),
                        "fixed": !p.identified,
                        "nominal": finite(p.nominal),
                        "identified": finite(p.estimate),
                        "std": optional(p.std),
                        "real": optional(real),
                        "error_before": optional(real.map(|r| p.nominal - r)),
                        "error_after": optional(real.map(|r| p.estimate - r)),
                    })
                })
                .collect();
            let run = result.runs.iter().find(|r| r.legs.contains(&leg.leg));
            let o = &leg.observability;
            let mut value = json!({
                "name": leg.leg,
                "measurements": leg.measurements,
                "parameters": parameters,
                "cost_before": finite(leg.initial_cost),
                "cost_after": finite(leg.final_cost),
                "residual_sigma": optional(leg.residual_sigma),
                "parameter_error_rms_before": optional(report.rms_error(leg, false)),
                "parameter_error_rms_after": optional(report.rms_error(leg, true)),
                "singular_values": o.singular_values.iter().map(|&s| finite(s)).collect::<Vec<_>>(),
                "condition_number": finite(o.condition),
                "scaled_condition_number": finite(o.scaled_condition),
                "warnings": o.warning().into_iter().chain(leg.warnings.iter().cloned()).collect::<Vec<_>>(),
                "noise_test": leg.statistics.noise_test.as_ref().map(|t| json!({
                    "chi_squared": finite(t.chi_squared),
                    "degrees_of_freedom": t.degrees_of_freedom,
                    "p_value": finite(t.p_value),
                    "sigma_ratio": finite(t.sigma_ratio),
                    "residual_sigma": finite(t.residual_sigma),
                    "expected_sigma": finite(t.expected_sigma),
                    "excluded_rows": t.excluded,
                    "rejected": t.rejected,
                })),
                "outlier_threshold": optional(leg.statistics.outlier_threshold),
                "outliers": leg.statistics.outliers.iter().map(outlier).collect::<Vec<_>>(),
                "dropped": leg.dropped.iter().map(outlier).collect::<Vec<_>>(),
                "observability": {
                    "O1": finite(o.indices[0]), "O2": finite(o.indices[1]), "O3": finite(o.indices[2]),
                    "O4": finite(o.indices[3]), "O5": finite(o.indices[4]),
                },
                "solver": run.map(|run| json!({
                    "name": result.solver.name(),
                    "legs": run.legs,
                    "iterations": run.iterations,
                    "converged": run.converged,
                    "stop_reason": run.stop_reason.key(),
                    "refinement_steps": run.refinement_steps,
                    "cost_before": finite(run.initial_cost),
                    "cost_after": finite(run.final_cost),
                    "residual_evaluations": run.residual_evaluations,
                    "jacobian_evaluations": run.jacobian_evaluations,
                    "seconds": finite(run.seconds),
                })),
            });
            merge(&mut value, leg_statistics(leg));
            value
        })
        .collect();
    json!({
        "strategy": result.strategy.name(),
        "solver": result.solver.short_name(),
        "weights": match result.options.weights {
            Weighting::Unweighted => "none",
            Weighting::Noise => "noise",
        },
        "robust": result.options.robust.map(|r| r.name()),
        "drop_outliers": result.options.drop_outliers,
        "warnings": all_warnings(result),
        "legs": legs,
        "fixed_legs": report.fixed_legs(result),
    })
}

fn outlier(o: &Outlier) -> Value {
    json!({
        "line": o.line,
        "pose": o.pose,
        "reading": finite(o.reading),
        "residual": finite(o.residual),
        "t": finite(o.t),
    })
}
