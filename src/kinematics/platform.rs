//! Platform forward kinematics: the measured pose reached for given actuator readings, by
//! Newton's method on all legs' closure equations at once, from the home configuration, staying
//! in the home assembly mode.
//!
//! Unknowns: the measured pose coordinates and every leg's passive joints; equations: every
//! leg's closure with its actuated joint at `gain·reading + offset`.

use nalgebra::{DMatrix, DVector, Vector3};

use super::chain::{attachment_on, platform_transform, ChainFrames};
use super::inverse::{joints, wrap_angle, Joints};
use super::kernel_forward::{KernelForward, KernelRows};
use super::newton_stop::converged;
use super::pose_derivative::pose_derivatives;
use super::reading::ReadingPredictor;
use crate::error::KinematicsError;
use crate::model::joint::JointKind;
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;

const MAX_ITERATIONS: usize = 50;

/// A converged configuration whose column-normalised closure Jacobian has a determinant
/// below this in magnitude is at a parallel singularity: no assembly mode to tell.
const SINGULAR_MODE: f64 = 1e-10;

/// A Newton step from a closure residual at most this fraction of the mechanism's size lands
/// at round-off (quadratic convergence): the next iteration checks the residual alone.
const LANDING: f64 = 1e-7;

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

impl Configuration {
    /// `mechanism` at home: its home pose with every leg's home joints.
    pub fn home(mechanism: &Mechanism) -> Self {
        Self {
            pose: mechanism.home_pose,
            joints: mechanism
                .legs
                .iter()
                .map(|l| joints(&l.home_joints))
                .collect(),
        }
    }
}

/// The forward kinematics of a mechanism at one parameter vector, prepared for many readings:
/// the legs' geometries and chain frames, the home readings and the home assembly mode are
/// computed once. Newton's method works in preallocated fixed storage.
pub struct ForwardKinematics<'m> {
    mechanism: &'m Mechanism,
    layout: Layout,
    geometries: Vec<LegGeometry<f64>>,
    frames: Vec<ChainFrames<f64>>,
    /// The smallest size the tolerances use: 1e-3 of the longest leg (its joint origins'
    /// offsets and its platform joint, end to end), for a platform whose joints all pass
    /// through the world origin.
    smallest_size: f64,
    /// The home readings and the sign of the home assembly mode, or why they do not exist.
    home: Result<(Vec<f64>, f64), KinematicsError>,
    /// The forward kinematics through the legs' closed-form kernels, when every leg has one,
    /// with the sign of its determinant at home ([`KernelForward`]): tried first by
    /// [`Self::solve_near`].
    kernel: Option<(KernelForward, f64)>,
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
        let longest = geometries
            .iter()
            .map(|g| {
                let offsets: f64 = g
                    .origins
                    .iter()
                    .map(|o| Vector3::new(o[0], o[1], o[2]).norm())
                    .sum();
                offsets + Vector3::from(g.attachment).norm()
            })
            .fold(0.0, f64::max);
        let mut solver = Self {
            mechanism,
            layout: layout(mechanism),
            geometries,
            frames,
            smallest_size: 1e-3 * longest,
            home: Err(KinematicsError::NotAssemblable {
                residual: f64::INFINITY,
            }),
            kernel: None,
        };
        solver.home = solver.home_assembly(params);
        solver.kernel = solver.kernel_assembly(longest);
        solver
    }

    fn home_assembly(&self, params: &[Vec<f64>]) -> Result<(Vec<f64>, f64), KinematicsError> {
        let home = self.mechanism.home_pose;
        let home_readings: Vec<f64> = self
            .mechanism
            .legs
            .iter()
            .zip(params)
            // Through a leg's kernel where it has one (the generic chain's reading to
            // round-off), as a simulation predicts it.
            .map(|(leg, phi)| ReadingPredictor::new(leg, phi).predict(&home, &home))
            .collect::<Result<_, _>>()?;
        let mut start = self.home_configuration();
        let sign = self.newton(&home_readings, &mut start)?.signum();
        Ok((home_readings, sign))
    }

    /// The reduced forward kinematics through the legs' kernels, if the mechanism has it and
    /// it closes at home (with the sign of its determinant there); `size` is the longest leg.
    fn kernel_assembly(&self, size: f64) -> Option<(KernelForward, f64)> {
        let (home_readings, _) = self.home.as_ref().ok()?;
        let kernel = KernelForward::new(self.mechanism, &self.geometries)?;
        let mut start = self.home_configuration();
        let joints = Some(start.joints.as_mut_slice());
        let determinant =
            kernel.newton(home_readings, &mut start.pose, joints, (size, false), None)?;
        Some((kernel, determinant.signum()))
    }

    /// The home pose with every leg's home joints.
    fn home_configuration(&self) -> Configuration {
        Configuration::home(self.mechanism)
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
                    Ok(sign) if same_mode(sign, home_sign) => {}
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
        if let Some((kernel, kernel_home_sign)) = &self.kernel {
            let (mut pose, mut joints) = (start.pose, start.joints.clone());
            let size = 1e3 * self.smallest_size;
            if let Some(sign) =
                kernel.newton(readings, &mut pose, Some(&mut joints), (size, false), None)
            {
                if same_mode(sign, *kernel_home_sign) {
                    start.pose = pose;
                    start.joints = joints;
                    return Ok(pose);
                }
            }
        }
        if start.joints.len() == self.mechanism.legs.len() {
            if let Ok(sign) = self.newton(readings, start) {
                if same_mode(sign, *home_sign) {
                    return Ok(start.pose);
                }
            }
        }
        self.solve(readings)
    }

    /// The pose reached for `readings` from `start`, as [`Self::solve_near`] finds it (the
    /// same pose, bit for bit), left in `start`: through the legs' kernels only the pose is
    /// closed and `start`'s joints are kept (the seed of a later stacked solve); through the
    /// stacked Newton the configuration is handed back as [`Self::solve_near`] does. A forward
    /// row's solve, whose legs are solved again at the pose for their derivatives.
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve_near_closed(
        &self,
        readings: &[f64],
        start: &mut Configuration,
    ) -> Result<[f64; 6], KinematicsError> {
        self.home.as_ref().map_err(Clone::clone)?;
        if let Some((kernel, kernel_home_sign)) = &self.kernel {
            let mut pose = start.pose;
            let size = 1e3 * self.smallest_size;
            if let Some(sign) = kernel.newton(readings, &mut pose, None, (size, true), None) {
                if same_mode(sign, *kernel_home_sign) {
                    start.pose = pose;
                    return Ok(pose);
                }
            }
        }
        self.solve_near(readings, start)
    }

    /// The pose reached for `readings` from `start`, as [`Self::solve_near`] finds it, without
    /// handing back the configuration: through the legs' kernels only their actuated joints
    /// are solved (an accuracy map's forward step).
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve_near_pose(
        &self,
        readings: &[f64],
        start: &Configuration,
    ) -> Result<[f64; 6], KinematicsError> {
        self.solve_near_pose_from(readings, start, None)
    }

    /// The legs' kernel rows at `pose` ([`KernelRows`]: each leg's actuated joint and its
    /// closure inverse's actuated row), when the mechanism's forward kinematics goes through
    /// its legs' kernels: the first evaluation of every [`Self::solve_near_pose_from`] started
    /// at `pose`, computed once.
    /// `None` also where the solve starts from a closed form instead (nothing to share).
    pub fn kernel_rows_at(&self, pose: &[f64; 6]) -> Option<KernelRows> {
        let kernel = self.kernel.as_ref().map(|(kernel, _)| kernel);
        let shared = kernel.filter(|kernel| !kernel.starts_in_closed_form());
        shared.map(|kernel| kernel.rows_at(pose))
    }

    /// [`Self::solve_near_pose`] with the legs' kernel rows at the start pose evaluated
    /// beforehand (`first`, [`Self::kernel_rows_at`] of the start's pose; ignored if they were
    /// evaluated elsewhere): the same pose, bit for bit, one kernel evaluation fewer.
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve_near_pose_from(
        &self,
        readings: &[f64],
        start: &Configuration,
        first: Option<&KernelRows>,
    ) -> Result<[f64; 6], KinematicsError> {
        self.home.as_ref().map_err(Clone::clone)?;
        if let Some((kernel, kernel_home_sign)) = &self.kernel {
            let mut pose = start.pose;
            let size = 1e3 * self.smallest_size;
            if let Some(sign) = kernel.newton(readings, &mut pose, None, (size, false), first) {
                if same_mode(sign, *kernel_home_sign) {
                    return Ok(pose);
                }
            }
        }
        self.solve_near(readings, &mut start.clone())
    }

    /// Newton on the stacked closures from `configuration` (updated in place); returns the
    /// determinant of the column-normalised FK Jacobian (its sign is the assembly mode).
    ///
    /// The tolerances are relative to the mechanism's size (the largest distance of a platform
    /// joint from the world origin, at least `smallest_size`), so a mechanism in kilometres or
    /// millimetres converges alike; a step is shortened so that no angle moves by more than
    /// 0.5 rad and no length by more than half that size.
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
                    self.frames[l].tip_and_jacobian(leg, &joints[l][..moving]);
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
            let tip = self.frames[l].tip(leg, &joints[l][..leg.moving.len()]);
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
        let layout = &self.layout;
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

/// Are two assembly-mode determinants of the same sign?
fn same_mode(determinant: f64, home: f64) -> bool {
    determinant.is_sign_positive() == home.is_sign_positive()
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
