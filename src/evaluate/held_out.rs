//! How well a model explains a measurement file, typically one held out of the fit.
//!
//! For every row holding all actuator readings, forward kinematics from the readings (home
//! assembly mode kept) gives the platform pose, compared with the measured one. For every row,
//! each leg's reading residual is the measured reading minus the one its inverse kinematics
//! predicts at the measured pose.
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
    pub position_error: Option<f64>,
    /// Orientation error (rad), where the model measures an orientation.
    pub orientation_error: Option<f64>,
}

/// Reading residuals of one leg over the rows (measured minus predicted by the leg's IK).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LegResidualStats {
    /// Leg name.
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
}

/// Evaluates the model `mechanism` (its nominal parameters) on the measurements `data`.
///
/// # Errors
/// [`Error::Measurement`] if no row holds every actuator reading.
pub fn evaluate(mechanism: &Mechanism, data: &MeasurementSet) -> Result<Evaluation> {
    let params = mechanism.nominal_parameters();
    let line = |index: usize| data.poses[index].line.unwrap_or(index + 2);
    let full: Vec<usize> = (0..data.poses.len())
        .filter(|&i| data.poses[i].readings.iter().all(Option::is_some))
        .collect();
    if full.is_empty() {
        return Err(Error::Measurement {
            path: data.source.clone().unwrap_or_else(|| "measurements".into()),
            location: "every row".into(),
            message: format!(
                "no row holds every actuator reading ({}); forward kinematics needs them all",
                mechanism.actuated_names().join(", ")
            ),
        });
    }
    let orientation = measures_orientation(mechanism);
    let row_errors: Vec<RowPoseError> = full
        .iter()
        .map(|&i| {
            let row = &data.poses[i];
            let readings: Vec<f64> = row.readings.iter().flatten().copied().collect();
            let reached = forward(mechanism, &params, &readings).ok();
            RowPoseError {
                line: line(i),
                position_error: reached.map(|p| position_error(&p, &row.pose)),
                orientation_error: reached
                    .filter(|_| orientation)
                    .map(|p| orientation_error(&p, &row.pose)),
            }
        })
        .collect();
    let reading_residual = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| {
            let mut residuals = Vec::new();
            let mut unreachable = Vec::new();
            for (i, row) in data.poses.iter().enumerate() {
                let Some(reading) = row.readings[l] else {
                    continue;
                };
                match predict_reading(leg, &params[l], &row.pose, &mechanism.home_pose) {
                    Ok(predicted) => residuals.push(reading - predicted),
                    Err(_) => unreachable.push(line(i)),
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
        .collect();
    let errors = |pick: fn(&RowPoseError) -> Option<f64>| -> Vec<f64> {
        row_errors.iter().filter_map(pick).collect()
    };
    Ok(Evaluation {
        model: mechanism.model_path.display().to_string(),
        measurements: data
            .source
            .as_ref()
            .map_or_else(|| "simulated".to_string(), |p| p.display().to_string()),
        rows: data.poses.len(),
        non_assemblable: row_errors
            .iter()
            .filter(|r| r.position_error.is_none())
            .map(|r| r.line)
            .collect(),
        position_error: ErrorStats::of(&errors(|r| r.position_error)),
        orientation_error: ErrorStats::of(&errors(|r| r.orientation_error)),
        row_errors,
        reading_residual,
    })
}
