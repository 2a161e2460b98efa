//! After the fit: how accurate a model is, in metres and radians.
//!
//! * [`accuracy`] — error statistics and the accuracy map (command a pose with a model's IK,
//!   move the real mechanism by forward kinematics, measure the pose error);
//! * [`held_out`] — how well a model explains a measurement file (poses by forward kinematics
//!   from the readings, per-leg reading residuals);
//! * [`through_instrument`] — the same through an instrument: where the model puts each target
//!   (forward kinematics from the readings, then the model's frame and offsets) against where
//!   the instrument saw it;
//! * [`observed_frame`] — a forward model's map error in the frame its observations define;
//! * [`predicted_position`] — a forward fit's covariance carried to its target over the
//!   workspace; [`predicted_pose`] — a fit from measured poses' to the end effector's position;
//! * their terminal (mm, mrad) and JSON renderings are [`crate::report::evaluation`]'s.
pub mod accuracy;
pub(crate) mod commanded_rows;
mod error_stats;
pub mod held_out;
pub mod observed_frame;
pub mod predicted_pose;
pub mod predicted_position;
pub mod row_residuals;
pub mod through_instrument;

use crate::error::Result;
use crate::measure::Measurements;
use crate::model::Mechanism;

/// Evaluates the model `mechanism` on `data` (typically held out of the fit): platform poses
/// by [`held_out::evaluate`], target coordinates through its instrument by
/// [`through_instrument::evaluate_observed`].
///
/// # Errors
/// No row holding every actuator reading, or measurements of another kind than the model's.
pub fn evaluate(mechanism: &Mechanism, data: &Measurements) -> Result<held_out::Evaluation> {
    let mut evaluation = match data {
        Measurements::Readings(set) => held_out::evaluate(mechanism, set),
        Measurements::Targets(observations) => {
            through_instrument::evaluate_observed(mechanism, observations)
        }
    }?;
    if let Some(set) = data.poses() {
        evaluation.warnings = crate::measure::checks::check(mechanism, set)?;
    }
    Ok(evaluation)
}
