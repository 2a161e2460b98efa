//! Error statistics and the accuracy map.
use serde::Serialize;

/// Summary of a set of non-negative errors (metres or radians).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Root mean square.
    pub rms: f64,
    /// Median (mean of the two middle values for an even count).
    pub median: f64,
    /// 95th percentile (linear interpolation between order statistics).
    pub p95: f64,
    /// Largest error.
    pub max: f64,
}

/// One commanded pose of an accuracy map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MapPoint {
    /// Target pose `[x, y, z, roll, pitch, yaw]` (m, rad).
    pub pose: [f64; 6],
    /// Position error of the real mechanism at this target (m); `None` when not assemblable.
    pub position_error: Option<f64>,
    /// Orientation error (rad) where the model measures an orientation and the point assembles.
    pub orientation_error: Option<f64>,
}

/// Pose errors over a grid of the usable region (the paper's accuracy map).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AccuracyMap {
    /// Grid spacing (m).
    pub grid_m: f64,
    /// Fraction of the workspace region covered (e.g. 0.95 of the MIW disc).
    pub scale: f64,
    /// Every grid point, assemblable or not.
    pub points: Vec<MapPoint>,
    /// Number of points that could not be reached (the model's IK or the real FK failed).
    pub non_assemblable: usize,
    /// Position errors over the assemblable points.
    pub position_error: ErrorStats,
    /// Orientation errors, when the model measures an orientation.
    pub orientation_error: Option<ErrorStats>,
}
