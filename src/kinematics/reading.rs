//! A leg's predicted reading at many poses for one parameter vector (a simulation's real
//! legs): [`super::inverse::predict_reading`] in f64 with the leg's geometry and chain frames built
//! once instead of at every pose. The same solve and the same arithmetic, so the same bits.

use super::chain::{attachment_world, ChainFrames};
use super::inverse::{reading_at, solve_from_home};
use crate::error::KinematicsError;
use crate::model::leg::{LegGeometry, LegModel};

/// [`super::inverse::predict_reading`] of one leg at one parameter vector, prepared for many poses.
#[derive(Debug, Clone)]
pub struct ReadingPredictor<'a> {
    leg: &'a LegModel,
    geometry: LegGeometry<f64>,
    frames: ChainFrames<f64>,
}

impl<'a> ReadingPredictor<'a> {
    /// `leg` at parameters `phi` (all the leg's parameters).
    pub fn new(leg: &'a LegModel, phi: &[f64]) -> Self {
        let geometry = leg.geometry(phi);
        let frames = ChainFrames::new(&geometry);
        Self {
            leg,
            geometry,
            frames,
        }
    }

    /// The predicted reading at `pose`: `inverse::predict_reading(leg, phi, pose, home_pose)`,
    /// bit for bit (the inverse kinematics from home on the generic chain, then one Newton
    /// step's correction of the actuated joint).
    ///
    /// # Errors
    /// As [`super::inverse::predict_reading`].
    pub fn predict(&self, pose: &[f64; 6], home_pose: &[f64; 6]) -> Result<f64, KinematicsError> {
        let (leg, geometry) = (self.leg, &self.geometry);
        let solution = solve_from_home(leg, geometry, &self.frames, pose, home_pose)?;
        let target = attachment_world(pose, &geometry.attachment);
        Ok(reading_at(leg, &self.frames, geometry, &target, &solution))
    }
}
