//! The stacked Newton of [`ForwardKinematics`]: every leg's closure equations at once, the
//! measured pose coordinates and every leg's passive joints as unknowns, each step limited in
//! angle and length; the path every pose the legs' kernels cannot settle takes.

use nalgebra::{DMatrix, DVector, Vector3};

use super::{Configuration, ForwardKinematics};
use crate::error::KinematicsError;
use crate::kinematics::chain::{attachment_on, platform_transform};
use crate::kinematics::inverse::{wrap_angle, Joints};
use crate::kinematics::newton_stop::converged;
use crate::kinematics::pose_derivative::pose_derivatives;
use crate::model::joint::JointKind;

const MAX_ITERATIONS: usize = 50;

/// A converged configuration whose column-normalised closure Jacobian has a determinant
/// below this in magnitude is at a parallel singularity: no assembly mode to tell.
const SINGULAR_MODE: f64 = 1e-10;

/// A Newton step from a closure residual at most this fraction of the mechanism's size lands
/// at round-off (quadratic convergence): the next iteration checks the residual alone.
const LANDING: f64 = 1e-7;

impl ForwardKinematics<'_> {
    /// Newton on the stacked closures from `configuration` (updated in place); returns the
    /// determinant of the column-normalised FK Jacobian (its sign is the assembly mode).
    ///
    /// The tolerances are relative to the mechanism's size (the largest distance of a platform
    /// joint from the world origin, at least `smallest_size`), so a mechanism in kilometres or
    /// millimetres converges alike; a step is shortened so that no angle moves by more than
    /// 0.5 rad and no length by more than half that size.
    pub(super) fn newton(
        &self,
        readings: &[f64],
        configuration: &mut Configuration,
    ) -> Result<f64, KinematicsError> {
        let mechanism = self.mechanism;
        let layout = self.layout();
        let (n, equations) = (layout.unknowns, layout.equations);
        if n != equations {
            return Err(KinematicsError::NotAssemblable {
                residual: f64::INFINITY,
            });
        }
        let Configuration { pose, joints } = configuration;
        for (l, leg) in mechanism.legs.iter().enumerate() {
            let geometry = &self.geometries[l];
            joints[l][leg.actuated] = geometry.gain * readings[l] + geometry.offset;
        }
        let mut f = DVector::zeros(n);
        let mut residual = f64::INFINITY;
        // The normalised determinant of the last step's Jacobian, when that step started from
        // a residual small enough for Newton's quadratic convergence to land at round-off.
        let mut landed: Option<f64> = None;
        for _ in 0..=MAX_ITERATIONS {
            let platform = platform_transform(pose);
            // After such a step the closure residual alone decides (the same tips as the full
            // iteration's, so the same decision); the assembly mode is the step's Jacobian's,
            // a round-off step away.
            if let Some(determinant) = landed.take() {
                let (check, size) = self.closure_residual(&platform, joints, &mut f);
                if !check.is_finite() {
                    return Err(KinematicsError::NotAssemblable { residual: check });
                }
                if converged(check, residual, 1e-13 * size) {
                    if determinant.abs() < SINGULAR_MODE {
                        return Err(KinematicsError::AssemblyModeChange);
                    }
                    return Ok(determinant);
                }
            }
            let mut jacobian = DMatrix::zeros(n, n);
            let pose_derivatives = pose_derivatives(pose, &layout.pose);
            let mut size = self.smallest_size;
            let mut row = 0;
            let mut column = layout.pose.len();
            for (l, leg) in mechanism.legs.iter().enumerate() {
                let geometry = &self.geometries[l];
                let moving = leg.moving.len();
                let (tip, tip_jacobian) =
                    (self.frames[l].get(geometry)).tip_and_jacobian(leg, &joints[l][..moving]);
                let target = attachment_on(&platform, &geometry.attachment);
                size = size.max(target.norm());
                let attachment = Vector3::from(geometry.attachment);
                for (k, derivative) in pose_derivatives.iter().take(layout.pose.len()).enumerate() {
                    let moved = derivative.rotation * attachment + derivative.translation;
                    for d in 0..leg.closure_dims {
                        jacobian[(row + d, k)] = -moved[d];
                    }
                }
                for &p in &layout.passive[l] {
                    for d in 0..leg.closure_dims {
                        jacobian[(row + d, column)] = tip_jacobian[(d, p)];
                    }
                    column += 1;
                }
                for d in 0..leg.closure_dims {
                    f[row + d] = tip[d] - target[d];
                }
                row += leg.closure_dims;
            }
            let previous = residual;
            residual = f.norm();
            if !residual.is_finite() {
                return Err(KinematicsError::NotAssemblable { residual });
            }
            let tolerance = 1e-13 * size;
            if converged(residual, previous, tolerance) {
                let determinant = normalised_determinant(jacobian);
                if determinant.abs() < SINGULAR_MODE {
                    return Err(KinematicsError::AssemblyModeChange);
                }
                return Ok(determinant);
            }
            let scales: f64 = jacobian
                .column_iter()
                .map(|c| c.norm().max(f64::MIN_POSITIVE))
                .product();
            let lu = jacobian.lu();
            let step = match lu.solve(&f) {
                Some(step) if step.iter().all(|v| v.is_finite()) => -step,
                _ => return Err(KinematicsError::NotAssemblable { residual }),
            };
            if residual <= LANDING * size {
                landed = Some(lu.determinant() / scales);
            }
            let scale = self.step_scale(&step, size);
            for (k, &c) in layout.pose.iter().enumerate() {
                pose[c] += scale * step[k];
            }
            let mut column = layout.pose.len();
            for (l, leg) in mechanism.legs.iter().enumerate() {
                for &p in &layout.passive[l] {
                    joints[l][p] += scale * step[column];
                    if self.is_angle(l, p) {
                        let home = leg.home_joints[p];
                        joints[l][p] = home + wrap_angle(joints[l][p] - home);
                    }
                    column += 1;
                }
            }
        }
        Err(KinematicsError::NotAssemblable { residual })
    }

    /// The stacked closure residual `f` (every leg's chain tip minus its platform joint) at
    /// `joints` and the platform `platform`, its norm and the mechanism's size there (as a
    /// Newton iteration computes them, without the Jacobian).
    fn closure_residual(
        &self,
        platform: &crate::kinematics::chain::Transform<f64>,
        joints: &[Joints],
        f: &mut DVector<f64>,
    ) -> (f64, f64) {
        let mut size = self.smallest_size;
        let mut row = 0;
        for (l, leg) in self.mechanism.legs.iter().enumerate() {
            let geometry = &self.geometries[l];
            let tip = (self.frames[l].get(geometry)).tip(leg, &joints[l][..leg.moving.len()]);
            let target = attachment_on(platform, &geometry.attachment);
            size = size.max(target.norm());
            for d in 0..leg.closure_dims {
                f[row + d] = tip[d] - target[d];
            }
            row += leg.closure_dims;
        }
        (f.norm(), size)
    }

    /// Is passive joint `p` (an index into the moving joints) of leg `l` revolute?
    fn is_angle(&self, l: usize, p: usize) -> bool {
        let leg = &self.mechanism.legs[l];
        leg.joints[leg.moving[p]].kind == JointKind::Revolute
    }

    /// The factor (at most 1) that keeps every angle of `step` within 0.5 rad and every length
    /// within half the mechanism's `size`.
    fn step_scale(&self, step: &DVector<f64>, size: f64) -> f64 {
        let layout = self.layout();
        let length = 0.5 * size.max(f64::MIN_POSITIVE);
        let mut largest = 0.0f64;
        for (k, &c) in layout.pose.iter().enumerate() {
            let unit = if c < 3 { length } else { 0.5 };
            largest = largest.max(step[k].abs() / unit);
        }
        let mut column = layout.pose.len();
        for (l, passive) in layout.passive.iter().enumerate() {
            for &p in passive {
                let unit = if self.is_angle(l, p) { 0.5 } else { length };
                largest = largest.max(step[column].abs() / unit);
                column += 1;
            }
        }
        1.0 / largest.max(1.0)
    }
}

/// Determinant of `a` with its columns scaled to unit norm (scale-free, in [−1, 1]); a zero
/// column stays zero.
fn normalised_determinant(mut a: DMatrix<f64>) -> f64 {
    for mut column in a.column_iter_mut() {
        let norm = column.norm().max(f64::MIN_POSITIVE);
        column /= norm;
    }
    a.determinant()
}

#[cfg(test)]
mod tests {
    use super::ForwardKinematics;
    use crate::model::Mechanism;
    use nalgebra::DVector;

    /// The step limit: angles within 0.5 rad, lengths within half the size; a step within both
    /// is left whole. On the 5R the unknowns are x, y and the two elbow angles.
    #[test]
    fn a_step_is_scaled_so_that_no_angle_passes_half_a_radian_and_no_length_half_the_size() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
        let mechanism = Mechanism::load(&path).unwrap();
        let kinematics = ForwardKinematics::new(&mechanism, &mechanism.nominal_parameters());
        let check = |step: [f64; 4], size: f64, expected: f64| {
            let scale = kinematics.step_scale(&DVector::from_column_slice(&step), size);
            assert!((scale - expected).abs() < 1e-15, "{step:?}: {scale}");
        };
        check([0.3, -0.2, 0.4, -0.1], 1.0, 1.0);
        check([3.0, 0.0, 0.0, 0.0], 2.0, 1.0 / 3.0); // 3 m against 1 m
        check([0.0, -0.5, 0.0, 0.0], 0.5, 0.5); // 0.5 m against 0.25 m
        check([0.1, 0.0, 2.0, 0.0], 2.0, 0.25); // 2 rad against 0.5 rad
        check([0.1, 0.0, 0.0, -1.0], 2.0, 0.5);
        check([4.0, 0.0, 0.0, -1.0], 2.0, 0.25); // the larger excess decides
                                                 // The hexapod: x y z roll pitch yaw, then two universal-joint angles per leg.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/hexapod.yaml");
        let hexapod = Mechanism::load(&path).unwrap();
        let kinematics = ForwardKinematics::new(&hexapod, &hexapod.nominal_parameters());
        for (index, expected) in [(2, 1.0), (3, 0.25), (5, 0.25), (17, 0.25)] {
            let mut step = DVector::zeros(18);
            step[index] = 2.0;
            let scale = kinematics.step_scale(&step, 8.0);
            assert!((scale - expected).abs() < 1e-15, "unknown {index}: {scale}");
        }
    }
}
