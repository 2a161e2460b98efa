//! Joint limits in the workspace: a pose is usable only if every leg reaches it with each
//! joint within its URDF `<limit>` (a prismatic joint's stroke, a revolute joint's range; see
//! [`crate::model::joint::JointModel::limits`]). The identification itself does not use them:
//! measured joints beyond a declared limit are still data.

use crate::error::{JointBeyondLimits, KinematicsError};
use crate::model::leg::LegModel;

/// Checks the moving joints' values `q` (in the order of `leg.moving`) against their limits.
///
/// # Errors
/// [`KinematicsError::BeyondLimits`] naming the first joint outside its range.
pub fn check_limits(leg: &LegModel, q: &[f64]) -> Result<(), KinematicsError> {
    for (&joint, &value) in leg.moving.iter().zip(q) {
        let joint = &leg.joints[joint];
        if let Some([lower, upper]) = joint.limits {
            if !(lower..=upper).contains(&value) {
                return Err(KinematicsError::BeyondLimits(Box::new(JointBeyondLimits {
                    leg: leg.name.clone(),
                    joint: joint.name.clone(),
                    value,
                    lower,
                    upper,
                })));
            }
        }
    }
    Ok(())
}

/// Does any joint of `leg` declare limits?
pub fn has_limits(leg: &LegModel) -> bool {
    leg.moving.iter().any(|&j| leg.joints[j].limits.is_some())
}
