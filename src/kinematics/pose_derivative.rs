//! The platform transform's derivatives with respect to pose coordinates: how a point of the
//! platform moves as one coordinate of the pose does (the forward kinematics' Jacobian columns).

use nalgebra::{Matrix3, Vector3};

/// The derivative of the platform transform with respect to one pose coordinate: a point `a`
/// of the platform moves at `rotation · a + translation`.
#[derive(Debug, Clone)]
pub(crate) struct PoseDerivative {
    pub(crate) rotation: Matrix3<f64>,
    pub(crate) translation: Vector3<f64>,
}

/// The platform transform's derivatives with respect to the pose coordinates `columns` (the
/// first `columns.len()` entries): a unit translation for a position; for an angle, the
/// rotation `Rz(yaw) Ry(pitch) Rx(roll)` with that angle's factor differentiated (one sine and
/// cosine per angle, shared by the three columns).
pub(crate) fn pose_derivatives(pose: &[f64; 6], columns: &[usize]) -> [PoseDerivative; 6] {
    let angles = columns.iter().any(|&c| c >= 3);
    let factors = angles.then(|| rotation_factors(pose));
    std::array::from_fn(|k| {
        let mut derivative = PoseDerivative {
            rotation: Matrix3::zeros(),
            translation: Vector3::zeros(),
        };
        match (columns.get(k), &factors) {
            (Some(&c), _) if c < 3 => derivative.translation[c] = 1.0,
            (Some(&c), Some([x, y, z])) => {
                let d = |i: usize, m: &[Matrix3<f64>; 2]| if c == i { m[1] } else { m[0] };
                derivative.rotation = d(5, z) * d(4, y) * d(3, x);
            }
            _ => {}
        }
        derivative
    })
}

/// The factors `Rx(roll)`, `Ry(pitch)`, `Rz(yaw)` of the pose's rotation, each with its
/// derivative with respect to its angle.
fn rotation_factors(pose: &[f64; 6]) -> [[Matrix3<f64>; 2]; 3] {
    let (sr, cr) = pose[3].sin_cos();
    let (sp, cp) = pose[4].sin_cos();
    let (sy, cy) = pose[5].sin_cos();
    #[rustfmt::skip]
    let factors = [
        [
            Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr),
            Matrix3::new(0.0, 0.0, 0.0, 0.0, -sr, -cr, 0.0, cr, -sr),
        ],
        [
            Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp),
            Matrix3::new(-sp, 0.0, cp, 0.0, 0.0, 0.0, -cp, 0.0, -sp),
        ],
        [
            Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0),
            Matrix3::new(-sy, -cy, 0.0, cy, -sy, 0.0, 0.0, 0.0, 0.0),
        ],
    ];
    factors
}

impl PoseDerivative {
    /// The velocity of the platform point `a` (platform coordinates).
    pub(crate) fn of(&self, a: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * a + self.translation
    }
}

#[cfg(test)]
mod tests {
    use num_dual::Dual64;

    use super::pose_derivatives;
    use crate::kinematics::chain::platform_transform;

    /// The closed-form rotation derivatives equal forward-mode dual numbers through the
    /// platform transform (to 1e-15), and a position's is the unit translation.
    #[test]
    fn the_pose_derivatives_equal_dual_numbers() {
        let pose = [0.1, -0.2, 0.6, 0.3, -0.7, 2.5];
        let columns = [0, 3, 4, 5, 2];
        let closed = pose_derivatives(&pose, &columns);
        for (k, &c) in columns.iter().enumerate() {
            let mut seeded = pose.map(Dual64::from);
            seeded[c].eps = 1.0;
            let transform = platform_transform(&seeded);
            let rotation = transform.rotation.matrix().map(|v| v.eps);
            let translation = transform.translation.vector.map(|v| v.eps);
            assert!((closed[k].rotation - rotation).amax() < 1e-15, "column {c}");
            assert!(
                (closed[k].translation - translation).amax() < 1e-15,
                "column {c}"
            );
        }
    }
}
