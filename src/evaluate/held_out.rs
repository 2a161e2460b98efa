//! How well a model explains a measurement file, typically one held out of the fit.
//!
//! For every row holding all actuator readings, forward kinematics from the readings (home
//! assembly mode kept) gives the platform pose, compared with the measured one. For every row,
//! each leg's reading residual is the measured reading minus the one its inverse kinematics
//! predicts at the measured pose. Measurements through an instrument are evaluated by
//! [`super::through_instrument`] into the same [`Evaluation`].
use std::path::Path;

use serde::Serialize;

use super::accuracy::{measures_orientation, orientation_error, position_error, ErrorStats};
use crate::error::{Error, Result};
use crate::kinematics::inverse::predict_reading;
use crate::kinematics::platform::forward;
use crate::measure::MeasurementSet;
use crate::model::Mechanism;

/// The pose error of one measurement row that holds every actuator reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RowPoseError {
    /// 1-based line of the row in the CSV file (the header is line 1); for measurements that
    /// were not read from a file, the line the row would have in a written file (index + 2).
    pub line: usize,
    /// Distance between the forward-kinematics position and the measured one (m); `None` when
    /// the mechanism cannot be assembled at these readings.
    #[serde(rename = "position_error_m")]
    pub position_error: Option<f64>,
    /// Orientation error (rad), where the model measures an orientation.
    #[serde(rename = "orientation_error_rad")]
    pub orientation_error: Option<f64>,
    /// Through an instrument: the index of the target these errors are of (one entry per row
    /// and target, [`Evaluation::targets`]); `None` for a measured platform pose.
    #[serde(skip)]
    pub target: Option<usize>,
}

/// Through an instrument: one target's errors over the assembled rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetErrors {
    /// The target's name.
    pub name: String,
    /// Distances between where the model puts the target and where the instrument saw it (m).
    #[serde(rename = "position_error_m")]
    pub position_error: Option<ErrorStats>,
    /// Orientation errors (rad), for a target whose pose the instrument measures.
    #[serde(rename = "orientation_error_rad")]
    pub orientation_error: Option<ErrorStats>,
}

/// Reading residuals of one leg over the rows (measured minus predicted by the leg's IK).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LegResidualStats {
    /// Leg name.
    #[serde(skip)]
    pub leg: String,
    /// Rows with the leg's reading that its inverse kinematics reaches.
    pub rows: usize,
    /// RMS of the residuals (reading units: rad or m); `None` without any residual.
    pub rms: Option<f64>,
    /// Largest absolute residual; `None` without any residual.
    pub max: Option<f64>,
    /// CSV lines of the rows with the leg's reading where its IK fails (pose out of reach, other
    /// working mode, serial singularity).
    pub unreachable: Vec<usize>,
}

/// How well one model explains one measurement file.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// Model file evaluated.
    pub model: String,
    /// Measurement file.
    pub measurements: String,
    /// Rows of the file.
    pub rows: usize,
    /// Pose errors, one per row that holds every actuator reading (in file order).
    pub row_errors: Vec<RowPoseError>,
    /// CSV lines of the full rows the mechanism cannot be assembled at.
    pub non_assemblable: Vec<usize>,
    /// Position errors over the assembled rows (m); `None` when no row assembles.
    pub position_error: Option<ErrorStats>,
    /// Orientation errors (rad), when the model measures an orientation and a row assembles.
    pub orientation_error: Option<ErrorStats>,
    /// Reading residuals per leg.
    pub reading_residual: Vec<LegResidualStats>,
    /// Seen through the forward kinematics with measured distances: the model's distance
    /// between its distance target's positions at the two rows minus the measured one, over
    /// the distances whose rows both assemble (m; the statistics of the absolute values).
    pub distance_error: Option<ErrorStats>,
    /// Distances measured (their rows may not assemble).
    pub distances: usize,
    /// Through an instrument, each target's errors (the instrument's order); empty for
    /// measured platform poses. `position_error` and `orientation_error` then cover every
    /// target at every assembled row.
    pub targets: Vec<TargetErrors>,
    /// Implausible values of the file for the model (readings or orientations in degrees,
    /// positions in millimetres), one line each ([`crate::measure::checks::check`]).
    pub warnings: Vec<String>,
}

impl Evaluation {
    /// The reasons this evaluation must not be trusted, one line each (empty: none): no row
    /// assembles, so there is no pose error at all, or the file holds implausible values.
    pub fn trust_issues(&self) -> Vec<String> {
        let mut issues = Vec::new();
        if self.position_error.is_none() {
            issues.push(format!(
                "{} on {}: no row can be assembled by the model's forward kinematics (lines {}): \
                 there is no pose error to report",
                self.model,
                self.measurements,
                lines(&self.non_assemblable)
            ));
        }
        issues.extend(
            self.warnings
                .iter()
                .map(|w| format!("{} on {}: {w}", self.model, self.measurements)),
        );
        issues
    }
}

/// CSV lines as `2, 3, 5` (the first ten, then how many more).
fn lines(lines: &[usize]) -> String {
    let shown: Vec<String> = lines.iter().take(10).map(usize::to_string).collect();
    match lines.len().saturating_sub(10) {
        0 => shown.join(", "),
        more => format!("{}, and {more} more", shown.join(", ")),
    }
}

/// Evaluates the model `mechanism` (its nominal parameters) on the measurements `data`.
///
/// # Errors
/// [`Error::Measurement`] if no row holds every actuator reading.
pub fn evaluate(mechanism: &Mechanism, data: &MeasurementSet) -> Result<Evaluation> {
    let params = mechanism.nominal_parameters();
    let line = |index: usize| data.poses()[index].line.unwrap_or(index + 2);
    let full: Vec<usize> = (0..data.len())
        .filter(|&i| data.readings(i).iter().all(Option::is_some))
        .collect();
    if full.is_empty() {
        return Err(no_full_row(mechanism, data.source.as_deref()));
    }
    let orientation = measures_orientation(mechanism);
    let row_errors: Vec<RowPoseError> = full
        .iter()
        .map(|&i| {
            let row = &data.poses()[i];
            let readings: Vec<f64> = data.readings(i).iter().flatten().copied().collect();
            let reached = forward(mechanism, &params, &readings).ok();
            RowPoseError {
                line: line(i),
                position_error: reached.map(|p| position_error(&p, &row.pose)),
                orientation_error: reached
                    .filter(|_| orientation)
                    .map(|p| orientation_error(&p, &row.pose)),
                target: None,
            }
        })
        .collect();
    let rows: Vec<ResidualRow<'_>> = data
        .rows()
        .enumerate()
        .map(|(i, (row, readings))| ResidualRow {
            line: line(i),
            readings,
            pose: row.pose,
        })
        .collect();
    let reading_residual = reading_residuals(mechanism, &params, &rows);
    let non_assemblable = row_errors
        .iter()
        .filter(|r| r.position_error.is_none())
        .map(|r| r.line)
        .collect();
    Ok(summarised(
        mechanism,
        data.source.as_deref(),
        data.len(),
        (row_errors, non_assemblable),
        reading_residual,
        Vec::new(),
    ))
}

/// The error of a file in which no row holds every actuator reading.
pub(super) fn no_full_row(mechanism: &Mechanism, source: Option<&Path>) -> Error {
    Error::Measurement {
        path: source.map_or_else(|| "measurements".into(), Path::to_path_buf),
        location: "every row".into(),
        message: format!(
            "no row holds every actuator reading ({}); forward kinematics needs them all",
            mechanism.actuated_names().join(", ")
        ),
    }
}

/// One row whose readings are compared with the inverse kinematics at a pose.
pub(super) struct ResidualRow<'a> {
    /// CSV line.
    pub(super) line: usize,
    /// Every leg's reading, `None` where not read.
    pub(super) readings: &'a [Option<f64>],
    /// The pose to predict the readings at.
    pub(super) pose: [f64; 6],
}

/// Each leg's reading residuals (measured minus predicted by its inverse kinematics with
/// `params`) over `rows`.
pub(super) fn reading_residuals(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    rows: &[ResidualRow<'_>],
) -> Vec<LegResidualStats> {
    mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| {
            let mut residuals = Vec::new();
            let mut unreachable = Vec::new();
            for row in rows {
                let Some(reading) = row.readings[l] else {
                    continue;
                };
                match predict_reading(leg, &params[l], &row.pose, &mechanism.home_pose) {
                    Ok(predicted) => residuals.push(reading - predicted),
                    Err(_) => unreachable.push(row.line),
                }
            }
            let magnitudes: Vec<f64> = residuals.iter().map(|r: &f64| r.abs()).collect();
            let stats = ErrorStats::of(&magnitudes);
            LegResidualStats {
                leg: leg.name.clone(),
                rows: residuals.len(),
                rms: stats.map(|s| s.rms),
                max: stats.map(|s| s.max),
                unreachable,
            }
        })
        .collect()
}

/// The evaluation of `rows` rows from `source` with these row errors (and the lines of the
/// full rows that do not assemble), reading residuals and per-target errors.
pub(super) fn summarised(
    mechanism: &Mechanism,
    source: Option<&Path>,
    rows: usize,
    (row_errors, non_assemblable): (Vec<RowPoseError>, Vec<usize>),
    reading_residual: Vec<LegResidualStats>,
    targets: Vec<TargetErrors>,
) -> Evaluation {
    let errors = |pick: fn(&RowPoseError) -> Option<f64>| -> Vec<f64> {
        row_errors.iter().filter_map(pick).collect()
    };
    Evaluation {
        model: mechanism.model_path.display().to_string(),
        measurements: source.map_or_else(|| "simulated".to_string(), |p| p.display().to_string()),
        rows,
        non_assemblable,
        position_error: ErrorStats::of(&errors(|r| r.position_error)),
        orientation_error: ErrorStats::of(&errors(|r| r.orientation_error)),
        row_errors,
        reading_residual,
        targets,
        distance_error: None,
        distances: 0,
        warnings: Vec::new(),
    }
}
