//! The report of an identification through the instrument: the instrument's parameters first,
//! then every leg's, for each strategy (joint and two-stage, compared), as terminal text and
//! JSON.

use serde_json::{json, Value};

use crate::identify::estimate::ParameterEstimate;
use crate::identify::shared_estimate::SharedEstimate;
use crate::model::Mechanism;

/// What the report shows.
#[derive(Debug, Clone)]
pub struct InstrumentReport<'a> {
    /// The model.
    pub mechanism: &'a Mechanism,
    /// Where the measurements came from.
    pub source: String,
    /// Real leg parameters of a simulation (per leg, model order).
    pub real: Option<Vec<Vec<f64>>>,
    /// Real instrument parameters of a simulation.
    pub real_shared: Option<Vec<f64>>,
    /// One result per strategy.
    pub results: Vec<SharedEstimate>,
}

fn line(p: &ParameterEstimate, real: Option<f64>) -> String {
    let std = p
        .std
        .map_or_else(|| "-".to_string(), |s| format!("{s:.2e}"));
    let status = if p.identified { "" } else { " (held)" };
    let real = real.map_or(String::new(), |r| {
        format!("  real {r:>12.7}  error {:>9.2e}", p.estimate - r)
    });
    format!(
        "  {:<14} {:>12.7} {:<3} σ {:>8}  nominal {:>10.6}{real}{status}\n",
        p.name, p.estimate, p.unit, std, p.nominal
    )
}

/// The terminal text.
pub fn render(report: &InstrumentReport<'_>) -> String {
    let mechanism = report.mechanism;
    let mut text = format!(
        "{}\nmeasurements: {} (through the instrument: {})\n",
        mechanism.name,
        report.source,
        mechanism
            .instrument
            .as_ref()
            .map(|i| i.columns().join(", "))
            .unwrap_or_default()
    );
    for result in &report.results {
        text.push_str(&format!(
            "\n{}: {} rows, {} unknowns, {} iterations{}, {:.3} s, RMS residual {:.3e}\n",
            result.strategy.name(),
            result.rows,
            result.unknowns,
            result.outcome.iterations,
            if result.outcome.converged {
                ""
            } else {
                " (NOT converged)"
            },
            result.seconds,
            result.rms
        ));
        if let Some(test) = &result.noise_test {
            text.push_str(&format!(
                "  residuals vs declared noise: σ̂/σ {:.3}, χ² {:.1} on {} dof, p = {:.3e}{}\n",
                test.sigma_ratio,
                test.chi_squared,
                test.degrees_of_freedom,
                test.p_value,
                if test.rejected { " (REJECTED)" } else { "" }
            ));
        }
        if let Some(test) = &result.held_frame {
            text.push_str(&format!(
                "  held frame ({}) vs freed: χ² drop {:.1} on {} dof, p = {:.3e}{}\n",
                test.freed.join(", "),
                test.chi_squared_drop,
                test.degrees_of_freedom,
                test.p_value,
                if test.rejected { " (REJECTED)" } else { "" }
            ));
        }
        text.push_str(" instrument\n");
        for (k, p) in result.shared.iter().enumerate() {
            text.push_str(&line(p, report.real_shared.as_ref().map(|r| r[k])));
        }
        for (leg, parameters) in &result.legs {
            text.push_str(&format!(" leg {}\n", mechanism.legs[*leg].name));
            for (k, p) in parameters.iter().enumerate() {
                text.push_str(&line(p, report.real.as_ref().map(|r| r[*leg][k])));
            }
        }
    }
    text
}

fn parameter_json(p: &ParameterEstimate, real: Option<f64>) -> Value {
    let mut value = json!({
        "name": p.name,
        "unit": p.unit.to_string(),
        "nominal": p.nominal,
        "estimate": p.estimate,
        "std": p.std,
        "identified": p.identified,
    });
    if let Some(real) = real {
        value["real"] = json!(real);
        value["error"] = json!(p.estimate - real);
    }
    value
}

/// The JSON report.
pub fn to_json(report: &InstrumentReport<'_>) -> Value {
    let mechanism = report.mechanism;
    let results: Vec<Value> = report
        .results
        .iter()
        .map(|result| {
            let shared: Vec<Value> = result
                .shared
                .iter()
                .enumerate()
                .map(|(k, p)| parameter_json(p, report.real_shared.as_ref().map(|r| r[k])))
                .collect();
            let legs: Vec<Value> = result
                .legs
                .iter()
                .map(|(leg, parameters)| {
                    json!({
                        "leg": mechanism.legs[*leg].name,
                        "parameters": parameters
                            .iter()
                            .enumerate()
                            .map(|(k, p)| parameter_json(p, report.real.as_ref().map(|r| r[*leg][k])))
                            .collect::<Vec<_>>(),
                    })
                })
                .collect();
            json!({
                "strategy": result.strategy.name(),
                "converged": result.outcome.converged,
                "stop_reason": result.outcome.stop_reason.to_string(),
                "iterations": result.outcome.iterations,
                "residual_evaluations": result.outcome.residual_evaluations,
                "seconds": result.seconds,
                "rows": result.rows,
                "unknowns": result.unknowns,
                "rms_residual": result.rms,
                "noise_test": result.noise_test.as_ref().map(|t| json!({
                    "chi_squared": t.chi_squared,
                    "degrees_of_freedom": t.degrees_of_freedom,
                    "p_value": t.p_value,
                    "sigma_ratio": t.sigma_ratio,
                    "rejected": t.rejected,
                })),
                "held_frame_test": result.held_frame.as_ref().map(|t| json!({
                    "freed": t.freed,
                    "chi_squared_drop": t.chi_squared_drop,
                    "degrees_of_freedom": t.degrees_of_freedom,
                    "p_value": t.p_value,
                    "rejected": t.rejected,
                    "estimates": t.estimates,
                })),
                "observability": {
                    "rank": result.observability.rank,
                    "scaled_condition": result.observability.scaled_condition,
                    "weakest_direction": result.observability.weakest_direction,
                },
                "instrument": shared,
                "legs": legs,
            })
        })
        .collect();
    json!({
        "model": mechanism.name,
        "model_file": mechanism.model_path.display().to_string(),
        "source": report.source,
        "instrument_columns": mechanism.instrument.as_ref().map(|i| i.columns()),
        "results": results,
    })
}
