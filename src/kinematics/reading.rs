//! A leg's predicted reading at many poses for one parameter vector (a simulation's real
//! legs): [`super::inverse::predict_reading`] in f64 with the leg's geometry, chain frames and
//! closed-form kernel built once instead of at every pose.

use super::chain::{attachment_world, LazyChainFrames};
use super::dyad::on_turn_of;
use super::inverse::{reading_at, solve_from_home};
use super::kernel::{LegKernel, PreparedKernel};
use crate::error::KinematicsError;
use crate::model::leg::{LegGeometry, LegModel};

/// [`super::inverse::predict_reading`] of one leg at one parameter vector, prepared for many poses.
#[derive(Debug, Clone)]
pub struct ReadingPredictor<'a> {
    leg: &'a LegModel,
    geometry: LegGeometry<f64>,
    frames: LazyChainFrames,
    /// The leg's closed-form kernel at these parameters, when its chain has one.
    kernel: Option<PreparedKernel<f64>>,
}

impl<'a> ReadingPredictor<'a> {
    /// `leg` at parameters `phi` (all the leg's parameters).
    pub fn new(leg: &'a LegModel, phi: &[f64]) -> Self {
        Self::with_kernel(leg, phi, LegKernel::recognise(leg))
    }

    /// As [`Self::new`], with `leg`'s kernel already recognised ([`LegKernel::recognise`]).
    pub fn with_kernel(leg: &'a LegModel, phi: &[f64], kernel: Option<LegKernel>) -> Self {
        let geometry = leg.geometry(phi);
        let frames = LazyChainFrames::new();
        let kernel = kernel.map(|kernel| kernel.prepare(&geometry));
        Self {
            leg,
            geometry,
            frames,
            kernel,
        }
    }

    /// The predicted reading at `pose`: `inverse::predict_reading(leg, phi, pose, home_pose)`.
    /// A leg with a closed-form kernel takes its actuated joint from it (on the turn of the home
    /// joints, where Newton's method from home lands): the same reading to round-off (about
    /// 1e-15 relative), one arc tangent instead of the generic chain's Newton solve. Every pose
    /// the kernel leaves to the generic solve (out of reach, near a reach limit, the other
    /// working mode) and every leg without a kernel take the generic chain: the inverse
    /// kinematics from home, then one Newton step's correction of the actuated joint.
    ///
    /// # Errors
    /// As [`super::inverse::predict_reading`].
    pub fn predict(&self, pose: &[f64; 6], home_pose: &[f64; 6]) -> Result<f64, KinematicsError> {
        let prepared = (&self.geometry, &self.frames, self.kernel.as_ref());
        predict_with(self.leg, prepared, pose, home_pose)
    }
}

/// [`ReadingPredictor::predict`] of `leg` from its geometry, chain frames and prepared kernel
/// (`prepared`, built by whoever has them already).
///
/// # Errors
/// As [`super::inverse::predict_reading`].
pub(crate) fn predict_with(
    leg: &LegModel,
    (geometry, frames, kernel): (
        &LegGeometry<f64>,
        &LazyChainFrames,
        Option<&PreparedKernel<f64>>,
    ),
    pose: &[f64; 6],
    home_pose: &[f64; 6],
) -> Result<f64, KinematicsError> {
    let target = attachment_world(pose, &geometry.attachment);
    if let Some((value, _)) = kernel.and_then(|k| k.actuated_row(&target)) {
        // A revolute's angle on the home turn; a prismatic joint's length as it is.
        let actuated = if leg.actuated_is_revolute() {
            on_turn_of(value, leg.home_joints[leg.actuated])
        } else {
            value
        };
        return Ok((actuated - geometry.offset) / geometry.gain);
    }
    let frames = frames.get(geometry);
    let solution = solve_from_home(leg, geometry, frames, pose, home_pose)?;
    Ok(reading_at(leg, frames, geometry, &target, &solution))
}
