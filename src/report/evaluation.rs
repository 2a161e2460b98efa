//! Terminal and JSON renderings of evaluations and accuracy maps (schema in `docs/report.md`).
//! The terminal shows millimetres and milliradians; the JSON keeps SI units.

use std::collections::BTreeMap;
use std::fmt::Write;

use serde::Serialize;
use serde_json::{json, Value};

use super::json::Document;
use crate::evaluate::accuracy::{AccuracyMap, ErrorStats};
use crate::evaluate::held_out::{Evaluation, LegResidualStats, RowPoseError, TargetErrors};
use crate::model::Mechanism;

/// One evaluation's document (docs/report.md), and the other model's as `"against"`.
#[derive(Debug, Serialize)]
struct EvaluationJson<'a> {
    model: &'a str,
    measurements: &'a str,
    rows: usize,
    full_rows: usize,
    non_assemblable: &'a [usize],
    position_error_m: Option<ErrorStats>,
    orientation_error_rad: Option<ErrorStats>,
    reading_residual: BTreeMap<&'a str, &'a LegResidualStats>,
    row_errors: Vec<RowJson<'a>>,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    targets: &'a [TargetErrors],
    #[serde(skip_serializing_if = "Option::is_none")]
    distance_error_m: Option<ErrorStats>,
    #[serde(skip_serializing_if = "is_zero")]
    distances: usize,
    warnings: &'a [String],
    #[serde(skip_serializing_if = "Option::is_none")]
    against: Option<Box<EvaluationJson<'a>>>,
}

impl<'a> EvaluationJson<'a> {
    fn new(evaluation: &'a Evaluation, against: Option<&'a Evaluation>) -> Self {
        EvaluationJson {
            model: &evaluation.model,
            measurements: &evaluation.measurements,
            rows: evaluation.rows,
            full_rows: evaluation.row_errors.len(),
            non_assemblable: &evaluation.non_assemblable,
            position_error_m: evaluation.position_error,
            orientation_error_rad: evaluation.orientation_error,
            reading_residual: evaluation
                .reading_residual
                .iter()
                .map(|leg| (leg.leg.as_str(), leg))
                .collect(),
            row_errors: evaluation
                .row_errors
                .iter()
                .map(|row| RowJson {
                    row,
                    target: row
                        .target
                        .and_then(|k| evaluation.targets.get(k))
                        .map(|t| t.name.as_str()),
                })
                .collect(),
            targets: &evaluation.targets,
            distance_error_m: evaluation.distance_error,
            distances: evaluation.distances,
            warnings: &evaluation.warnings,
            against: against.map(|other| Box::new(EvaluationJson::new(other, None))),
        }
    }
}

/// No distances measured: the key is left out.
fn is_zero(count: &usize) -> bool {
    *count == 0
}

/// One row's errors, with the name of the target they are of.
#[derive(Debug, Serialize)]
struct RowJson<'a> {
    #[serde(flatten)]
    row: &'a RowPoseError,
    #[serde(skip_serializing_if = "Option::is_none")]
    target: Option<&'a str>,
}

/// The `legwise evaluate` JSON document: header, the evaluation, and `"against"`. Made a
/// [`Value`], whose objects sort their keys: the document's keys are in alphabetical order.
pub fn evaluation_json(evaluation: &Evaluation, against: Option<&Evaluation>) -> Value {
    json!(Document::new(EvaluationJson::new(evaluation, against)))
}

/// Millimetres (or milliradians) with three significant-looking decimals.
fn milli(value: Option<f64>) -> String {
    value.map_or_else(|| "-".into(), |v| format!("{:.4}", 1e3 * v))
}

/// `other / this` as "12.3x", when both are positive.
fn factor(this: Option<f64>, other: Option<f64>) -> String {
    match (this, other) {
        (Some(a), Some(b)) if a > 0.0 && b.is_finite() => format!("{:.1}x", b / a),
        _ => "-".into(),
    }
}

/// The lines of one statistics block: rows `RMS median p95 max` with one column per evaluation.
fn stats_rows(
    text: &mut String,
    title: &str,
    unit: &str,
    columns: &[Option<&ErrorStats>],
    improvement: bool,
) {
    type Pick = fn(&ErrorStats) -> f64;
    let picks: [(&str, Pick); 4] = [
        ("RMS", |s| s.rms),
        ("median", |s| s.median),
        ("p95", |s| s.p95),
        ("max", |s| s.max),
    ];
    let _ = writeln!(text, "{title} ({unit})");
    for (name, pick) in picks {
        let values: Vec<Option<f64>> = columns.iter().map(|s| s.map(pick)).collect();
        let mut line = format!("  {name:<8}");
        for v in &values {
            let _ = write!(line, "{:>18}", milli(*v));
        }
        if improvement {
            let _ = write!(line, "{:>14}", factor(values[0], values[1]));
        }
        let _ = writeln!(text, "{line}");
    }
}

fn lines_text(lines: &[usize]) -> String {
    const SHOWN: usize = 12;
    let mut text = lines
        .iter()
        .take(SHOWN)
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(", ");
    if lines.len() > SHOWN {
        let _ = write!(text, ", … ({} in all)", lines.len());
    }
    text
}

/// The terminal report of `legwise evaluate` (mm and mrad), side by side with `against`.
pub fn evaluation_text(
    mechanism: &Mechanism,
    evaluation: &Evaluation,
    against: Option<&Evaluation>,
) -> String {
    let mut text = String::new();
    // Seen through the forward kinematics, a row of a measured pose has every reading too.
    let full = match mechanism.forward_instrument() {
        Some(_) => "with target coordinates and every actuator reading",
        None => "with every actuator reading",
    };
    let _ = writeln!(
        text,
        "legwise evaluate: {} on {} ({} rows, {} {full})",
        evaluation.model,
        evaluation.measurements,
        evaluation.rows,
        evaluation.row_errors.len()
    );
    let evaluations: Vec<&Evaluation> = std::iter::once(evaluation).chain(against).collect();
    let mut head = format!("{:<10}", "");
    for (i, e) in evaluations.iter().enumerate() {
        let name = std::path::Path::new(&e.model)
            .file_name()
            .map_or_else(|| e.model.clone(), |n| n.to_string_lossy().into_owned());
        let label = if i == 0 { name } else { format!("vs {name}") };
        // At least one space between two names, however long.
        let _ = write!(head, " {label:>17}");
    }
    if against.is_some() {
        let _ = write!(head, "{:>14}", "improvement");
    }
    let _ = writeln!(text, "\n{head}");
    let improvement = against.is_some();
    let position: Vec<_> = evaluations
        .iter()
        .map(|e| e.position_error.as_ref())
        .collect();
    let through = !evaluation.targets.is_empty();
    let title = if through {
        "target position error, the model's (forward kinematics from the readings, then its \
         instrument frame and offsets) vs the instrument's"
    } else {
        "position error, forward kinematics from the readings"
    };
    stats_rows(&mut text, title, "mm", &position, improvement);
    if evaluations.iter().any(|e| e.orientation_error.is_some()) {
        let orientation: Vec<_> = evaluations
            .iter()
            .map(|e| e.orientation_error.as_ref())
            .collect();
        let title = if through {
            "target orientation error"
        } else {
            "orientation error"
        };
        stats_rows(&mut text, title, "mrad", &orientation, improvement);
    }
    if evaluation.targets.len() > 1 {
        for (k, target) in evaluation.targets.iter().enumerate() {
            let of = |pick: fn(&TargetErrors) -> Option<&ErrorStats>| -> Vec<Option<&ErrorStats>> {
                evaluations
                    .iter()
                    .map(|e| e.targets.get(k).and_then(pick))
                    .collect()
            };
            let title = format!("target `{}`: position error", target.name);
            stats_rows(
                &mut text,
                &title,
                "mm",
                &of(|t| t.position_error.as_ref()),
                improvement,
            );
            if target.orientation_error.is_some() {
                let title = format!("target `{}`: orientation error", target.name);
                let values = of(|t| t.orientation_error.as_ref());
                stats_rows(&mut text, &title, "mrad", &values, improvement);
            }
        }
    }
    if evaluations.iter().any(|e| e.distance_error.is_some()) {
        let distance: Vec<_> = evaluations
            .iter()
            .map(|e| e.distance_error.as_ref())
            .collect();
        let title = format!(
            "distance error, |the model's distance between its target at the two rows - the \
             measured one| ({} distances)",
            evaluation.distances
        );
        stats_rows(&mut text, &title, "mm", &distance, improvement);
    }
    // Seen through the forward kinematics the targets give no pose: reading residuals only at
    // the rows of a measured pose (`instrument.poses`), if there are any.
    match mechanism.forward_instrument() {
        None => residual_rows(&mut text, mechanism, &evaluations, through),
        Some(_) => {
            let measured = |e: &&Evaluation| e.reading_residual.iter().any(|r| r.rms.is_some());
            if evaluations.iter().any(measured) {
                residual_rows(&mut text, mechanism, &evaluations, false);
            }
        }
    }
    for e in &evaluations {
        if !e.non_assemblable.is_empty() {
            let _ = writeln!(
                text,
                "{}: cannot be assembled at the readings of {} row(s), CSV lines {}",
                e.model,
                e.non_assemblable.len(),
                lines_text(&e.non_assemblable)
            );
        }
        for leg in &e.reading_residual {
            if !leg.unreachable.is_empty() {
                let _ = writeln!(
                    text,
                    "{}: leg `{}` cannot reach the measured pose of CSV lines {}",
                    e.model,
                    leg.leg,
                    lines_text(&leg.unreachable)
                );
            }
        }
    }
    text
}

/// The reading residual rows of each leg, side by side over `evaluations`.
fn residual_rows(
    text: &mut String,
    mechanism: &Mechanism,
    evaluations: &[&Evaluation],
    through: bool,
) {
    let improvement = evaluations.len() > 1;
    let residual_title = if through {
        "reading residual, measured - predicted by the leg's IK at the pose fitted from the targets"
    } else {
        "reading residual, measured - predicted by the leg's IK"
    };
    let _ = writeln!(text, "{residual_title}");
    for (l, leg) in mechanism.legs.iter().enumerate() {
        let unit = if leg.actuated_is_revolute() {
            "mrad"
        } else {
            "mm"
        };
        for (name, pick) in [("RMS", 0), ("max", 1)] {
            let values: Vec<Option<f64>> = evaluations
                .iter()
                .map(|e| {
                    e.reading_residual
                        .get(l)
                        .and_then(|r| if pick == 0 { r.rms } else { r.max })
                })
                .collect();
            let mut line = format!("  {:<8}", format!("{} {name}", leg.name));
            for v in &values {
                let _ = write!(line, "{:>13} {unit:<4}", milli(*v));
            }
            if improvement {
                let _ = write!(line, "{:>14}", factor(values[0], values[1]));
            }
            let _ = writeln!(text, "{line}");
        }
    }
}

/// One line summarising an accuracy map in millimetres (and milliradians).
pub fn map_summary(label: &str, map: &AccuracyMap) -> String {
    let p = &map.position_error;
    let mut text = format!(
        "{label}: position error RMS {} mm, median {} mm, p95 {} mm, max {} mm",
        milli(Some(p.rms)),
        milli(Some(p.median)),
        milli(Some(p.p95)),
        milli(Some(p.max)),
    );
    if let Some(o) = &map.orientation_error {
        let _ = write!(
            text,
            "; orientation error RMS {} mrad, max {} mrad",
            milli(Some(o.rms)),
            milli(Some(o.max))
        );
    }
    let _ = write!(
        text,
        "; not assemblable: {} of {} points",
        map.non_assemblable,
        map.points.len()
    );
    text
}
