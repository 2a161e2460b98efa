//! Residual blocks: one leg × one measured pose (Ceres' residual block).

use crate::error::KinematicsError;
use crate::kinematics::inverse::predict_reading;
use crate::model::leg::LegModel;
use crate::scalar::{lift, Scalar};

/// One measured pose and one leg's measured actuator reading at it.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualBlock {
    /// Index of the leg.
    pub leg: usize,
    /// Measured platform pose `[x, y, z, roll, pitch, yaw]` (metres, radians).
    pub pose: [f64; 6],
    /// Measured raw actuator reading.
    pub reading: f64,
    /// Line of the measurement file the pose came from (1-based, counting the header), if any.
    pub line: Option<usize>,
}

impl ResidualBlock {
    /// Predicted minus measured reading for the leg's full parameter vector `phi`, in any
    /// scalar (e.g. dual numbers in the parameters or the pose). One-off evaluation: for many
    /// blocks at one parameter vector, [`crate::identify::jacobian::PreparedLeg`] reuses the
    /// leg's geometry.
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
        Ok(predicted - lift::<T>(self.reading))
    }
}
