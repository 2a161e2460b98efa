//! How well a model explains a measurement file.
use serde::Serialize;

use super::accuracy::ErrorStats;

/// The pose error of one measurement row that holds every actuator reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RowPoseError {
    /// 1-based line of the row in the CSV file (the header is line 1).
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
    /// RMS of the residuals.
    pub rms: f64,
    /// Largest absolute residual.
    pub max: f64,
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
