//! The Monte Carlo study as text (terminal) and JSON (every trial's values included, so that
//! each statistic can be recomputed from them).

use serde_json::{json, Value};

use super::montecarlo::{Arm, MonteCarlo, Trial};
use super::stats::Estimate;
use crate::report::json::Document;

/// An estimate as JSON: `{"value", "ci95": [low, high]}` (non-finite numbers are `null`).
pub fn estimate_json(estimate: &Estimate) -> Value {
    json!({
        "value": estimate.value,
        "ci95": [estimate.low, estimate.high],
    })
}

/// One trial as JSON, its arms' values keyed by `arms` (the study's order).
fn trial_json(trial: &Trial, order: &[Arm]) -> Value {
    match &trial.outcome {
        Ok(values) => {
            let arms: serde_json::Map<_, _> = order
                .iter()
                .zip(&values.arms)
                .map(|(arm, values)| (arm.key().into(), json!(values)))
                .collect();
            json!({
                "index": trial.index,
                "seed": trial.seed,
                "failure": null,
                "nominal_map_rms_m": values.nominal_map_rms,
                "real": values.real,
                "arms": arms,
            })
        }
        Err(reason) => json!({
            "index": trial.index,
            "seed": trial.seed,
            "failure": reason,
        }),
    }
}

/// The study as JSON: options, the summary per arm and parameter, the comparisons, the
/// verdict, and every trial.
pub fn montecarlo_json(study: &MonteCarlo) -> Value {
    let options = &study.options;
    let arm_order: Vec<Arm> = study.arms.iter().map(|a| a.arm).collect();
    let arms: Vec<Value> = study
        .arms
        .iter()
        .map(|arm| {
            let parameters: Vec<Value> = study
                .parameters
                .iter()
                .zip(&arm.parameters)
                .map(|(p, s)| {
                    json!({
                        "name": p.name,
                        "unit": p.unit.to_string(),
                        "mean_error": estimate_json(&s.mean),
                        "std_error": estimate_json(&s.std),
                        "rms_error": estimate_json(&s.rms),
                        "predicted_std": estimate_json(&s.predicted_std),
                    })
                })
                .collect();
            json!({
                "arm": arm.arm.key(),
                "name": arm.arm.name(),
                "poses": arm.poses,
                "map_rms_m": estimate_json(&arm.map_rms),
                "alarms": {
                    "outlier_tests": arm.alarms.outlier_tests,
                    "flagged": arm.alarms.flagged,
                    "flagged_fraction": estimate_json(&arm.flagged),
                    "noise_tests": arm.alarms.noise_tests,
                    "rejected": arm.alarms.rejected,
                    "rejected_fraction": estimate_json(&arm.rejected),
                    "tolerance_tests": arm.alarms.tolerance_tests,
                    "above_tolerance": arm.alarms.above_tolerance,
                    "above_tolerance_fraction": estimate_json(&arm.above_tolerance),
                },
                "parameters": parameters,
            })
        })
        .collect();
    let comparisons: Vec<Value> = study
        .comparisons
        .iter()
        .map(|c| {
            json!({
                "first": c.first.key(),
                "second": c.second.key(),
                "map_rms_difference_m": estimate_json(&c.difference),
                "sentence": c.sentence,
            })
        })
        .collect();
    let mut body = json!({
        "mechanism": study.mechanism,
        "trials": options.trials,
        "succeeded": study.succeeded,
        "failed": options.trials - study.succeeded,
        "seed": options.seed,
        "solver": options.solver.short_name(),
        "noise_scale": options.noise_scale,
        "map": {
            "grid_m": options.map_grid,
            "scale": options.map_scale,
            "points": study.map_points,
        },
        "parameters": study.parameters.iter().map(|p| json!({"name": p.name, "unit": p.unit.to_string()})).collect::<Vec<_>>(),
        "nominal_map_rms_m": estimate_json(&study.nominal_map_rms),
        "arms": arms,
        "comparisons": comparisons,
        "verdict": study.verdict,
        "per_trial": study.trials.iter().map(|t| trial_json(t, &arm_order)).collect::<Vec<_>>(),
    });
    if let Some(frame) = &study.map_frame {
        body["map"]["frame"] = json!(frame);
    }
    json!(Document::new(body))
}

/// `value [low, high]` with three significant digits.
fn interval(estimate: &Estimate, factor: f64) -> String {
    let e = estimate.scaled(factor);
    format!("{} [{}, {}]", short(e.value), short(e.low), short(e.high))
}

/// An estimate in metres as millimetres in fixed notation, four decimals (`16.8403 [16.8401,
/// 16.8405]`): the map errors and their differences.
fn millimetres(estimate: &Estimate) -> String {
    let e = estimate.scaled(1e3);
    let fixed = |v: f64| {
        if v.is_finite() {
            format!("{v:.4}")
        } else {
            "-".into()
        }
    };
    format!("{} [{}, {}]", fixed(e.value), fixed(e.low), fixed(e.high))
}

/// The observed spread over the predicted σ, three decimals (`-` without a σ).
fn ratio(value: f64) -> String {
    if value.is_finite() {
        format!("{value:.3}")
    } else {
        "-".into()
    }
}

/// A proportion in per cent with its interval and counts: `0.75 % [0.61, 0.92] (90 of 12000)`,
/// `-` without any test.
fn percentage(fraction: &Estimate, count: usize, of: usize) -> String {
    if of == 0 {
        return "- (none run)".into();
    }
    let e = fraction.scaled(100.0);
    format!(
        "{:.2} % [{:.2}, {:.2}] ({count} of {of})",
        e.value, e.low, e.high
    )
}

fn short(value: f64) -> String {
    if !value.is_finite() {
        return "-".into();
    }
    format!("{value:.3e}")
}

/// The study for the terminal: set-up, per-parameter statistics per arm, the map errors, the
/// comparisons and the verdict.
pub fn montecarlo_text(study: &MonteCarlo) -> String {
    let options = &study.options;
    let mut text = format!(
        "Monte Carlo study of {}: {} trials ({} failed), seed {}, {}, noise scale {}\n",
        study.mechanism,
        options.trials,
        options.trials - study.succeeded,
        options.seed,
        options.solver.name(),
        options.noise_scale
    );
    let poses: Vec<String> = study
        .arms
        .iter()
        .map(|a| format!("{} {}", a.arm.name(), a.poses))
        .collect();
    text.push_str(&format!("poses measured: {}\n", poses.join(", ")));
    text.push_str(&format!(
        "accuracy map: {} points, grid {} m over {} of the workspace region\n",
        study.map_points, options.map_grid, options.map_scale
    ));
    text.push_str(
        "\nparameter errors (estimate - real, SI units), 95 % confidence intervals in brackets:\n",
    );
    for (p, parameter) in study.parameters.iter().enumerate() {
        text.push_str(&format!("  {} ({})\n", parameter.name, parameter.unit));
        for arm in &study.arms {
            let s = &arm.parameters[p];
            text.push_str(&format!(
                "    {:<26} mean {}  std {}  RMS {}  predicted σ {}  std/σ {}\n",
                arm.arm.name(),
                interval(&s.mean, 1.0),
                interval(&s.std, 1.0),
                interval(&s.rms, 1.0),
                interval(&s.predicted_std, 1.0),
                ratio(s.std.value / s.predicted_std.value)
            ));
        }
    }
    text.push_str("\nRMS position error over the map (mm), mean over the trials:\n");
    if let Some(frame) = &study.map_frame {
        text.push_str(&format!("  ({frame})\n"));
    }
    text.push_str(&format!(
        "    {:<26} {}\n",
        "nominal model",
        millimetres(&study.nominal_map_rms)
    ));
    for arm in &study.arms {
        text.push_str(&format!(
            "    {:<26} {}\n",
            arm.arm.name(),
            millimetres(&arm.map_rms)
        ));
    }
    text.push_str(
        "\nchecks of bad data on these clean data (false alarms; 95 % Wilson intervals):\n",
    );
    for arm in &study.arms {
        text.push_str(&format!(
            "    {:<26} leg fits flagging a row {}; noise tests rejecting the declared noise {}\n",
            arm.arm.name(),
            percentage(&arm.flagged, arm.alarms.flagged, arm.alarms.outlier_tests),
            percentage(&arm.rejected, arm.alarms.rejected, arm.alarms.noise_tests),
        ));
        if arm.alarms.tolerance_tests > 0 {
            text.push_str(&format!(
                "    {:<26} predicted σ above the model's tolerance (the warning, exit 3) {}\n",
                arm.arm.name(),
                percentage(
                    &arm.above_tolerance,
                    arm.alarms.above_tolerance,
                    arm.alarms.tolerance_tests
                ),
            ));
        }
    }
    text.push_str("\npaired comparisons (same draws in every arm):\n");
    for c in &study.comparisons {
        text.push_str(&format!(
            "    {} - {}: {} mm\n",
            c.first.name(),
            c.second.name(),
            millimetres(&c.difference)
        ));
    }
    text.push_str(&format!("\nverdict: {}\n", study.verdict));
    text
}

#[cfg(test)]
mod tests {
    use super::{interval, millimetres, Estimate};

    #[test]
    fn an_interval_prints_its_scaled_value_and_bounds_to_three_significant_digits() {
        // Millimetres from metres: the factor multiplies all three numbers.
        let estimate = Estimate {
            value: 0.002,
            low: -0.0005,
            high: 0.0125,
        };
        assert_eq!(interval(&estimate, 1e3), "2.000e0 [-5.000e-1, 1.250e1]");
        assert_eq!(interval(&estimate, 1.0), "2.000e-3 [-5.000e-4, 1.250e-2]");
        // An interval that does not exist (fewer than two trials) prints dashes.
        let none = Estimate {
            value: 1.5,
            low: f64::NAN,
            high: f64::INFINITY,
        };
        assert_eq!(interval(&none, 1.0), "1.500e0 [-, -]");
        // Map errors: millimetres in fixed notation.
        assert_eq!(millimetres(&estimate), "2.0000 [-0.5000, 12.5000]");
        assert_eq!(millimetres(&none), "1500.0000 [-, -]");
    }
}
