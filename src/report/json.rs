//! The JSON report (`--json PATH`): the same data as the terminal report. Non-finite numbers
//! are written as `null`, never as NaN.

use serde_json::{json, Value};

use super::terminal::all_warnings;
use super::IdentifyReport;
use crate::identify::estimate::{StrategyResult, Weighting};
use crate::identify::statistics::Outlier;

fn finite(value: f64) -> Value {
    if value.is_finite() {
        json!(value)
    } else {
        Value::Null
    }
}

fn optional(value: Option<f64>) -> Value {
    value.map_or(Value::Null, finite)
}

/// The report as a JSON value.
pub fn to_json(report: &IdentifyReport<'_>) -> Value {
    json!({
        "mechanism": report.mechanism.name,
        "model": report.mechanism.model_path.display().to_string(),
        "mode": report.mechanism.mode,
        "measurements": report.source,
        "units": "SI (m, rad); costs are 1/2 ||r||^2 in reading units squared",
        "results": report.results.iter().map(|r| result(report, r)).collect::<Vec<_>>(),
    })
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
            json!({
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
                    "cost_before": finite(run.initial_cost),
                    "cost_after": finite(run.final_cost),
                    "residual_evaluations": run.residual_evaluations,
                    "jacobian_evaluations": run.jacobian_evaluations,
                    "seconds": finite(run.seconds),
                })),
            })
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
