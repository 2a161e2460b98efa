//! The platform transform's derivatives with respect to pose coordinates: how a point of the
//! platform moves as one coordinate of the pose does (the forward kinematics' Jacobian columns).

use nalgebra::{Matrix3, Vector3};
use num_dual::Dual64;

use super::chain::platform_transform;

/// The derivative of the platform transform with respect to one pose coordinate: a point `a`
/// of the platform moves at `rotation · a + translation`.
#[derive(Debug, Clone)]
pub(crate) struct PoseDerivative {
    pub(crate) rotation: Matrix3<f64>,
    pub(crate) translation: Vector3<f64>,
}

/// The platform transform's derivatives with respect to the pose coordinates `columns` (the
/// first `columns.len()` entries): a unit translation for a position, forward-mode dual numbers
/// for an angle.
pub(crate) fn pose_derivatives(pose: &[f64; 6], columns: &[usize]) -> [PoseDerivative; 6] {
    std::array::from_fn(|k| {
        let mut derivative = PoseDerivative {
            rotation: Matrix3::zeros(),
            translation: Vector3::zeros(),
        };
        match columns.get(k) {
            Some(&c) if c < 3 => derivative.translation[c] = 1.0,
            Some(&c) => {
                let mut seeded = pose.map(Dual64::from);
                seeded[c].eps = 1.0;
                let transform = platform_transform(&seeded);
                derivative.rotation = transform.rotation.matrix().map(|v| v.eps);
                derivative.translation = transform.translation.vector.map(|v| v.eps);
            }
            None => {}
        }
        derivative
    })
}

impl PoseDerivative {
    /// The velocity of the platform point `a` (platform coordinates).
    pub(crate) fn of(&self, a: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * a + self.translation
    }
}
