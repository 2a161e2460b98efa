//! Residual blocks: one leg × one measured pose (Ceres' residual block).
//!
//! A revolute actuated joint's angle is periodic: the joint angle the leg's inverse kinematics
//! predicts (on the turn of the leg's home value) and the one the reading gives through the
//! actuator model (`q = gain · reading + offset`) are matched modulo 2π, so a home value or a
//! reading on another turn never drags an identified offset by 2πk. In reading units, a whole
//! turn is `2π / gain`.

use std::f64::consts::TAU;

use crate::error::KinematicsError;
use crate::kinematics::inverse::predict_reading;
use crate::model::leg::LegModel;
use crate::scalar::{lift, Scalar};

/// Defined with the measurements (below identification in the module graph).
pub use crate::measure::ResidualBlock;

/// Largest number of whole turns matched away: a joint angle farther from its prediction is a
/// wrong value (an outlier the statistics name), not a turn ambiguity.
pub const MAX_TURNS: f64 = 100.0;

/// Whole turns of the actuated joint between the predicted and the measured reading, for a
/// revolute actuator with gain `gain`: `round(gain · (predicted − reading) / 2π)`; zero for a
/// prismatic actuator, a non-finite difference or more than [`MAX_TURNS`] turns.
pub fn turns(predicted: f64, reading: f64, gain: f64, revolute: bool) -> f64 {
    let turns = (gain * (predicted - reading) / TAU).round();
    if revolute && turns.is_finite() && turns.abs() <= MAX_TURNS {
        turns
    } else {
        0.0
    }
}

/// One whole turn of the actuated joint in reading units: `2π / gain`.
pub fn turn_in_reading_units<T: Scalar>(gain: T) -> T {
    lift::<T>(TAU) / gain
}

impl ResidualBlock {
    /// Predicted minus measured reading for the leg's full parameter vector `phi`, in any
    /// scalar (e.g. dual numbers in the parameters or the pose), matched modulo one turn for a
    /// revolute actuator. One-off evaluation: for many blocks at one parameter vector,
    /// [`crate::identify::problem::IdentificationProblem`] reuses the leg's geometry.
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn evaluate<T: Scalar>(
        &self,
        leg: &LegModel,
        phi: &[T],
        home_pose: &[f64; 6],
    ) -> Result<T, KinematicsError> {
        let pose = self.pose.map(lift::<T>);
        let predicted = predict_reading(leg, phi, &pose, home_pose)?;
        let gain = leg.geometry(phi).gain;
        let n = turns(
            predicted.re(),
            self.reading,
            gain.re(),
            leg.actuated_is_revolute(),
        );
        Ok(predicted - lift::<T>(self.reading) - turn_in_reading_units(gain) * lift::<T>(n))
    }
}
