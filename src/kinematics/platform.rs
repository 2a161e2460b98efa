//! Platform forward kinematics: the measured pose reached for given actuator readings, by
//! Newton's method on all legs' closure equations at once, from the home configuration, staying
//! in the home assembly mode.
//!
//! Unknowns: the measured pose coordinates and every leg's passive joints; equations: every
//! leg's closure with its actuated joint at `gain·reading + offset`.

use nalgebra::{Matrix3, Vector3};
use num_dual::Dual64;

use super::chain::{attachment_on, platform_transform, ChainFrames};
use super::inverse::{joints, predict_reading, wrap_angle, Joints};
use crate::error::KinematicsError;
use crate::model::joint::JointKind;
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;

const MAX_ITERATIONS: usize = 50;

/// The unknowns' layout and the home assembly sign.
struct Layout {
    /// Columns of the pose coordinates (indices into the 6-pose).
    pose: Vec<usize>,
    /// Per leg, the indices (into the leg's moving joints) of the passive joints.
    passive: Vec<Vec<usize>>,
    /// Number of unknowns (pose coordinates and passive joints).
    unknowns: usize,
    /// Number of closure equations of all legs.
    equations: usize,
}

fn layout(mechanism: &Mechanism) -> Layout {
    let passive: Vec<Vec<usize>> = mechanism
        .legs
        .iter()
        .map(|leg| {
            (0..leg.moving.len())
                .filter(|&i| i != leg.actuated)
                .collect()
        })
        .collect();
    Layout {
        pose: mechanism.measured.clone(),
        unknowns: mechanism.measured.len() + passive.iter().map(Vec::len).sum::<usize>(),
        equations: mechanism.legs.iter().map(|l| l.closure_dims).sum(),
        passive,
    }
}

/// Forward kinematics for readings `readings` (one per leg) with parameters `params` (one full
/// vector per leg). Readings are continued from the home readings to stay on the home assembly.
/// For many readings at one parameter vector, build a [`ForwardKinematics`] once instead.
///
/// # Errors
/// [`KinematicsError::NotAssemblable`], [`KinematicsError::AssemblyModeChange`], or a
/// mechanism whose unknowns and equations do not match (reported as not assemblable).
pub fn forward(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    readings: &[f64],
) -> Result<[f64; 6], KinematicsError> {
    ForwardKinematics::new(mechanism, params).solve(readings)
}

/// A configuration of the whole mechanism: the platform pose and every leg's moving joints
/// (the actuated one included; see [`Joints`]). The start of [`ForwardKinematics::solve_near`].
#[derive(Debug, Clone, PartialEq)]
pub struct Configuration {
    /// The pose `[x, y, z, roll, pitch, yaw]`.
    pub pose: [f64; 6],
    /// Per leg, its moving joints' values.
    pub joints: Vec<Joints>,
}

/// The forward kinematics of a mechanism at one parameter vector, prepared for many readings:
/// the legs' geometries and chain frames, the home readings and the home assembly mode are
/// computed once. Newton's method works in preallocated fixed storage.
pub struct ForwardKinematics<'m> {
    mechanism: &'m Mechanism,
    layout: Layout,
    geometries: Vec<LegGeometry<f64>>,
    frames: Vec<ChainFrames<f64>>,
    /// The home readings and the sign of the home assembly mode, or why they do not exist.
    home: Result<(Vec<f64>, f64), KinematicsError>,
}

impl<'m> ForwardKinematics<'m> {
    /// Prepares the forward kinematics of `mechanism` with parameters `params` (one full vector
    /// per leg). A failure at home (a leg that cannot reach the home pose, a home that does not
    /// assemble) is returned by every solve.
    pub fn new(mechanism: &'m Mechanism, params: &[Vec<f64>]) -> Self {
        let geometries: Vec<LegGeometry<f64>> = mechanism
            .legs
            .iter()
            .zip(params)
            .map(|(l, p)| l.geometry(p))
            .collect();
        let frames = geometries.iter().map(ChainFrames::new).collect();
        let mut solver = Self {
            mechanism,
            layout: layout(mechanism),
            geometries,
            frames,
            home: Err(KinematicsError::NotAssemblable {
                residual: f64::INFINITY,
            }),
        };
        solver.home = solver.home_assembly(params);
        solver
    }

    fn home_assembly(&self, params: &[Vec<f64>]) -> Result<(Vec<f64>, f64), KinematicsError> {
        let home = self.mechanism.home_pose;
        let home_readings: Vec<f64> = self
            .mechanism
            .legs
            .iter()
            .zip(params)
            .map(|(leg, phi)| predict_reading(leg, phi, &home, &home))
            .collect::<Result<_, _>>()?;
        let mut start = self.home_configuration();
        let sign = self.newton(&home_readings, &mut start)?.signum();
        Ok((home_readings, sign))
    }

    /// The home pose with every leg's home joints.
    fn home_configuration(&self) -> Configuration {
        Configuration {
            pose: self.mechanism.home_pose,
            joints: self
                .mechanism
                .legs
                .iter()
                .map(|l| joints(&l.home_joints))
                .collect(),
        }
    }

    /// The pose reached for `readings` (one per leg), continued from the home readings to stay
    /// on the home assembly mode (as [`forward`]).
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve(&self, readings: &[f64]) -> Result<[f64; 6], KinematicsError> {
        let (home_readings, home_sign) = self.home.clone()?;
        for steps in [1usize, 8, 32] {
            let mut trial = self.home_configuration();
            let mut ok = true;
            for step in 1..=steps {
                let t = step as f64 / steps as f64;
                let target: Vec<f64> = home_readings
                    .iter()
                    .zip(readings)
                    .map(|(h, r)| h + t * (r - h))
                    .collect();
                match self.newton(&target, &mut trial) {
                    Ok(sign) if sign * home_sign > 0.0 => {}
                    _ => {
                        ok = false;
                        break;
                    }
                }
            }
            if ok {
                return Ok(trial.pose);
            }
        }
        let mut start = self.home_configuration();
        match self.newton(readings, &mut start) {
            Ok(_) => Err(KinematicsError::AssemblyModeChange),
            Err(err) => Err(err),
        }
    }

    /// The pose reached for `readings`, by Newton from `start` (a configuration near the
    /// answer, e.g. the target pose of an accuracy map with the legs' joints there): accepted
    /// if it converges in the home assembly mode (the sign [`Self::solve`] checks), else solved
    /// as [`Self::solve`] does. Leaves the converged configuration in `start`.
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve_near(
        &self,
        readings: &[f64],
        start: &mut Configuration,
    ) -> Result<[f64; 6], KinematicsError> {
        let (_, home_sign) = self.home.as_ref().map_err(Clone::clone)?;
        if start.joints.len() == self.mechanism.legs.len() {
            if let Ok(sign) = self.newton(readings, start) {
                if sign * home_sign > 0.0 {
                    return Ok(start.pose);
                }
            }
        }
        self.solve(readings)
    }

    /// Newton on the stacked closures from `configuration` (updated in place); returns the
    /// determinant of the column-normalised FK Jacobian (its sign is the assembly mode).
    fn newton(
        &self,
        readings: &[f64],
        configuration: &mut Configuration,
    ) -> Result<f64, KinematicsError> {
        let mechanism = self.mechanism;
        let layout = &self.layout;
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
        let mut jacobian = vec![0.0; n * n];
        let mut f = vec![0.0; n];
        let mut residual = f64::INFINITY;
        for _ in 0..=MAX_ITERATIONS {
            // The factorisation of the last iteration overwrote the matrix.
            jacobian.fill(0.0);
            let platform = platform_transform(pose);
            let pose_derivatives = pose_derivatives(pose, &layout.pose);
            let mut row = 0;
            let mut column = layout.pose.len();
            for (l, leg) in mechanism.legs.iter().enumerate() {
                let geometry = &self.geometries[l];
                let moving = leg.moving.len();
                let (tip, tip_jacobian) =
                    self.frames[l].tip_and_jacobian(leg, &joints[l][..moving]);
                let target = attachment_on(&platform, &geometry.attachment);
                let attachment = Vector3::from(geometry.attachment);
                for (k, derivative) in pose_derivatives.iter().take(layout.pose.len()).enumerate() {
                    let moved = derivative.rotation * attachment + derivative.translation;
                    for d in 0..leg.closure_dims {
                        jacobian[(row + d) * n + k] = -moved[d];
                    }
                }
                for &p in &layout.passive[l] {
                    for d in 0..leg.closure_dims {
                        jacobian[(row + d) * n + column] = tip_jacobian[(d, p)];
                    }
                    column += 1;
                }
                for d in 0..leg.closure_dims {
                    f[row + d] = tip[d] - target[d];
                }
                row += leg.closure_dims;
            }
            let previous = residual;
            residual = f.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !residual.is_finite() {
                return Err(KinematicsError::NotAssemblable { residual });
            }
            if residual < 1e-13 || (residual < 1e-10 && residual >= 0.5 * previous) {
                let determinant = normalised_determinant(&mut jacobian, n);
                if determinant.abs() < 1e-10 {
                    return Err(KinematicsError::AssemblyModeChange);
                }
                return Ok(determinant);
            }
            for v in &mut f {
                *v = -*v;
            }
            if !lu_solve(&mut jacobian, n, &mut f) {
                return Err(KinematicsError::NotAssemblable { residual });
            }
            let step = &f;
            let largest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let scale = if largest > 0.5 { 0.5 / largest } else { 1.0 };
            for (k, &c) in layout.pose.iter().enumerate() {
                pose[c] += scale * step[k];
            }
            let mut column = layout.pose.len();
            for (l, leg) in mechanism.legs.iter().enumerate() {
                for &p in &layout.passive[l] {
                    joints[l][p] += scale * step[column];
                    if leg.joints[leg.moving[p]].kind == JointKind::Revolute {
                        let home = leg.home_joints[p];
                        joints[l][p] = home + wrap_angle(joints[l][p] - home);
                    }
                    column += 1;
                }
            }
        }
        Err(KinematicsError::NotAssemblable { residual })
    }
}

/// The derivative of the platform transform with respect to one pose coordinate: a point `a`
/// of the platform moves at `rotation · a + translation`.
struct PoseDerivative {
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
}

/// The platform transform's derivatives with respect to the pose coordinates `columns` (the
/// first `columns.len()` entries): a unit translation for a position, forward-mode dual numbers
/// for an angle.
fn pose_derivatives(pose: &[f64; 6], columns: &[usize]) -> [PoseDerivative; 6] {
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

/// Solves `a x = b` in place (`a`: `n × n`, row-major, overwritten by its LU factors; `b`
/// becomes `x`) by Gaussian elimination with partial pivoting. `false` if `a` is singular.
fn lu_solve(a: &mut [f64], n: usize, b: &mut [f64]) -> bool {
    for k in 0..n {
        let pivot = (k..n)
            .max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs()))
            .unwrap_or(k);
        if a[pivot * n + k] == 0.0 || !a[pivot * n + k].is_finite() {
            return false;
        }
        if pivot != k {
            for j in 0..n {
                a.swap(k * n + j, pivot * n + j);
            }
            b.swap(k, pivot);
        }
        let diagonal = a[k * n + k];
        for i in k + 1..n {
            let factor = a[i * n + k] / diagonal;
            if factor != 0.0 {
                for j in k + 1..n {
                    a[i * n + j] -= factor * a[k * n + j];
                }
                b[i] -= factor * b[k];
            }
        }
    }
    for k in (0..n).rev() {
        let sum: f64 = (k + 1..n).map(|j| a[k * n + j] * b[j]).sum();
        b[k] = (b[k] - sum) / a[k * n + k];
    }
    b.iter().all(|v| v.is_finite())
}

/// Determinant of `a` (`n × n`, row-major) with its columns scaled to unit norm (scale-free,
/// in [−1, 1]); overwrites `a`.
fn normalised_determinant(a: &mut [f64], n: usize) -> f64 {
    for c in 0..n {
        let norm = (0..n)
            .map(|r| a[r * n + c] * a[r * n + c])
            .sum::<f64>()
            .sqrt();
        if norm > 0.0 {
            for r in 0..n {
                a[r * n + c] /= norm;
            }
        }
    }
    let mut determinant = 1.0;
    for k in 0..n {
        let pivot = (k..n)
            .max_by(|&i, &j| a[i * n + k].abs().total_cmp(&a[j * n + k].abs()))
            .unwrap_or(k);
        if a[pivot * n + k] == 0.0 {
            return 0.0;
        }
        if pivot != k {
            for j in 0..n {
                a.swap(k * n + j, pivot * n + j);
            }
            determinant = -determinant;
        }
        let diagonal = a[k * n + k];
        determinant *= diagonal;
        for i in k + 1..n {
            let factor = a[i * n + k] / diagonal;
            for j in k + 1..n {
                a[i * n + j] -= factor * a[k * n + j];
            }
        }
    }
    determinant
}

#[cfg(test)]
mod tests {
    use super::{lu_solve, normalised_determinant};
    use nalgebra::{DMatrix, DVector};

    fn matrix() -> DMatrix<f64> {
        DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 2.0, -1.0, 3.0, 1.5, -0.5, 4.0, 0.2, -2.0, 1.0, 0.3, -1.0, 0.7, 0.0, 2.5, 1.1,
            ],
        )
    }

    fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
        m.transpose().as_slice().to_vec()
    }

    #[test]
    fn lu_solve_agrees_with_nalgebra_and_refuses_a_singular_matrix() {
        let m = matrix();
        let b = DVector::from_column_slice(&[1.0, -2.0, 0.5, 3.0]);
        let expected = m.clone().lu().solve(&b).unwrap();
        let mut a = row_major(&m);
        let mut x = b.as_slice().to_vec();
        assert!(lu_solve(&mut a, 4, &mut x));
        for (got, want) in x.iter().zip(expected.iter()) {
            assert!((got - want).abs() < 1e-13, "{got} against {want}");
        }
        // Two equal rows.
        let mut singular = vec![1.0, 2.0, 1.0, 2.0];
        assert!(!lu_solve(&mut singular, 2, &mut [1.0, 1.0]));
    }

    #[test]
    fn normalised_determinant_agrees_with_nalgebra_on_unit_columns() {
        let mut m = matrix();
        for mut c in m.column_iter_mut() {
            let n = c.norm();
            c /= n;
        }
        let expected = m.determinant();
        let mut a = row_major(&matrix());
        let got = normalised_determinant(&mut a, 4);
        assert!((got - expected).abs() < 1e-14, "{got} against {expected}");
        assert!(expected.abs() > 0.05, "a test matrix far from singular");
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(normalised_determinant(&mut singular, 2).abs() < 1e-15);
    }
}
