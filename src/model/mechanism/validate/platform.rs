//! The platform at home: with as many legs as measured coordinates, the parallel (type II)
//! measure must not vanish there. A degenerate platform (attachment points that coincide or
//! line up) can move with every actuator locked: forward kinematics, the assembly mode and
//! pose selection all break down, so it is refused when the model is loaded.

use super::Builder;
use crate::error::{KinematicsError, Result};
use crate::kinematics::singularity::ParallelMeasure;
use crate::model::Mechanism;

/// Parallel measure (unit-norm rows, in [−1, 1]) at or below which the home pose is degenerate.
pub(super) const DEGENERATE_PARALLEL_MEASURE: f64 = 1e-8;

impl Builder<'_> {
    pub(super) fn platform(&self, mechanism: &Mechanism) -> Result<()> {
        let measure = match ParallelMeasure::new(mechanism, mechanism.nominal_parameters()) {
            Ok(measure) => measure.at(&mechanism.home_pose).map_err(|e| e.to_string()),
            Err(KinematicsError::NotSquare { .. }) => return Ok(()),
            Err(KinematicsError::AssemblyModeChange) => Ok(0.0),
            Err(other) => Err(other.to_string()),
        };
        let value = match measure {
            Ok(value) if value.abs() > DEGENERATE_PARALLEL_MEASURE => return Ok(()),
            Ok(value) => format!("{value:.1e}"),
            Err(message) => format!("undefined ({message})"),
        };
        Err(self.error(
            "legs[*].attachment",
            format!(
                "the platform is degenerate at the home pose: its parallel (type II) measure is \
                 {value} (0: the platform moves with every actuator locked); the attachment \
                 points must not coincide or line up, and the legs must not all meet in one point \
                 or lie in one plane with the platform"
            ),
        ))
    }
}
