//! The usable workspace of a mechanism (validated `workspace` block): the region, an inward
//! safety margin, and ranges for the measured coordinates the region does not cover.
//! Containment and sampling are [`crate::workspace::region`]'s.

use super::region::Region;

/// The usable workspace of a mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Workspace {
    /// Region of the end-effector point: in x, y (planar) or in x, y, z (spatial).
    pub region: Region,
    /// Inward safety margin, metres.
    pub margin: f64,
    /// `[min, max]` for coordinates 2..6 (z roll pitch yaw) that vary; `None` keeps the home
    /// value (z of a spatial region comes from the region, never from a range).
    pub ranges: [Option<[f64; 2]>; 6],
    /// Candidate grid spacing for pose selection, metres.
    pub grid: Option<f64>,
    /// Evenly spaced values of each ranged coordinate in the candidate grid.
    pub range_levels: usize,
    /// Smallest allowed serial (type I) measure of a candidate pose.
    pub serial_threshold: f64,
    /// Smallest allowed parallel (type II) measure of a candidate pose.
    pub parallel_threshold: f64,
}

/// Default smallest serial and parallel singularity measures of a candidate pose.
pub const DEFAULT_SINGULARITY_THRESHOLD: f64 = 0.05;
/// Default number of values of each ranged coordinate in the candidate grid.
pub const DEFAULT_RANGE_LEVELS: usize = 9;
/// Most values of a ranged coordinate in the candidate grid: each level multiplies the grid,
/// which already holds thousands of positions, and a grid beyond a few million poses is refused.
pub const MAX_RANGE_LEVELS: usize = 1000;
