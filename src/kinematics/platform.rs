//! Platform forward kinematics: the measured pose reached for given actuator readings, staying
//! in the home assembly mode: on the measured pose alone through the legs' closed-form kernels
//! where every leg has one (`kernel_forward.rs`), else (and for every pose the kernels cannot
//! settle) by Newton's method on all legs' closure equations at once (`platform/stacked.rs`),
//! continued from the home configuration when a nearby start does not converge.
//!
//! Unknowns of the stacked Newton: the measured pose coordinates and every leg's passive
//! joints; equations: every leg's closure with its actuated joint at `gain·reading + offset`.

use std::sync::OnceLock;

use nalgebra::Vector3;

use super::chain::LazyChainFrames;
use super::inverse::{joints, Joints};
use super::kernel::{prepare_each, LegKernel, PreparedKernel};
use super::kernel_forward::{KernelForward, KernelRows};
use super::reading::predict_with;
use crate::error::KinematicsError;
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;

mod stacked;

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
    /// The stacked Newton's unknowns and equations, worked out the first time it runs (a
    /// solve through the legs' kernels never needs them).
    layout: OnceLock<Layout>,
    geometries: Vec<LegGeometry<f64>>,
    frames: Vec<LazyChainFrames>,
    /// The smallest size the tolerances use: 1e-3 of the longest leg (its joint origins'
    /// offsets and its platform joint, end to end), for a platform whose joints all pass
    /// through the world origin.
    smallest_size: f64,
    /// The home readings, or why a leg cannot reach the home pose.
    home_readings: Result<Vec<f64>, KinematicsError>,
    /// The sign of the home assembly mode by the stacked Newton at home, or why it does not
    /// close there: computed when a solve first needs it (one through the kernels does not).
    home_sign: OnceLock<Result<f64, KinematicsError>>,
    /// The forward kinematics through the legs' closed-form kernels, when every leg has one and
    /// they assemble at the home readings, with the sign of its determinant at home
    /// ([`KernelForward`]): tried first by [`Self::solve_near`].
    kernel: Option<(KernelForward, f64)>,
}

impl<'m> ForwardKinematics<'m> {
    /// Prepares the forward kinematics of `mechanism` with parameters `params` (one full vector
    /// per leg). A failure at home (a leg that cannot reach the home pose, a home that does not
    /// assemble) is returned by every solve (where the legs' kernels assemble at home, the
    /// mechanism does: their solves need no other check).
    pub fn new(mechanism: &'m Mechanism, params: &[Vec<f64>]) -> Self {
        let kernels: Vec<_> = mechanism.legs.iter().map(LegKernel::recognise).collect();
        Self::with_kernels(mechanism, params, &kernels)
    }

    /// As [`Self::new`], with every leg's closed-form kernel already recognised (`kernels`, one
    /// per leg: [`LegKernel::recognise`] of it; a problem evaluated at many parameter vectors
    /// recognises them once).
    pub fn with_kernels(
        mechanism: &'m Mechanism,
        params: &[Vec<f64>],
        kernels: &[Option<LegKernel>],
    ) -> Self {
        let geometries: Vec<LegGeometry<f64>> = mechanism
            .legs
            .iter()
            .zip(params)
            .map(|(l, p)| l.geometry(p))
            .collect();
        let frames = geometries.iter().map(|_| LazyChainFrames::new()).collect();
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
            layout: OnceLock::new(),
            geometries,
            frames,
            smallest_size: 1e-3 * longest,
            home_readings: Err(KinematicsError::NotAssemblable {
                residual: f64::INFINITY,
            }),
            home_sign: OnceLock::new(),
            kernel: None,
        };
        // Each leg's kernel prepared once, for the home readings and the kernels' assembly.
        let prepared = prepare_each(kernels, &solver.geometries);
        solver.home_readings = solver.home_readings(&prepared);
        solver.kernel = match &solver.home_readings {
            Ok(readings) => solver.kernel_assembly(readings, longest, &prepared),
            Err(_) => None,
        };
        solver
    }

    /// The home readings and the sign of the home assembly mode by the stacked Newton (solved
    /// at the first call), or why they do not exist.
    fn home(&self) -> Result<(&[f64], f64), KinematicsError> {
        let readings = self.home_readings.as_ref().map_err(Clone::clone)?;
        let sign = self.home_sign.get_or_init(|| {
            let mut start = self.home_configuration();
            self.newton(readings, &mut start).map(f64::signum)
        });
        Ok((readings, sign.clone()?))
    }

    /// Every leg's reading at the home pose.
    fn home_readings(
        &self,
        kernels: &[Option<PreparedKernel<f64>>],
    ) -> Result<Vec<f64>, KinematicsError> {
        let home = self.mechanism.home_pose;
        let legs = self.mechanism.legs.iter().zip(&self.geometries);
        let home_readings: Vec<f64> = (legs.zip(&self.frames).zip(kernels))
            // Through a leg's kernel where it has one (the generic chain's reading to
            // round-off), as a simulation predicts it.
            .map(|(((leg, geometry), frames), kernel)| {
                predict_with(leg, (geometry, frames, kernel.as_ref()), &home, &home)
            })
            .collect::<Result<_, _>>()?;
        Ok(home_readings)
    }

    /// The reduced forward kinematics through the legs' kernels, if the mechanism has it and
    /// it closes at home for `home_readings` (with the sign of its determinant there); `size`
    /// is the longest leg.
    fn kernel_assembly(
        &self,
        home_readings: &[f64],
        size: f64,
        kernels: &[Option<PreparedKernel<f64>>],
    ) -> Option<(KernelForward, f64)> {
        let kernel = KernelForward::with_prepared(self.mechanism, &self.geometries, kernels)?;
        let mut start = self.home_configuration();
        let joints = Some(start.joints.as_mut_slice());
        let determinant =
            kernel.newton(home_readings, &mut start.pose, joints, (size, false), None)?;
        Some((kernel, determinant.signum()))
    }

    /// The stacked Newton's unknowns and equations ([`Layout`]).
    fn layout(&self) -> &Layout {
        self.layout.get_or_init(|| layout(self.mechanism))
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
        let (home_readings, home_sign) = self.home()?;
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
        let (_, home_sign) = self.home()?;
        if start.joints.len() == self.mechanism.legs.len() {
            if let Ok(sign) = self.newton(readings, start) {
                if same_mode(sign, home_sign) {
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
    /// row's solve, whose legs are differentiated at the pose. The legs' kernel rows there
    /// ([`KernelRows`]) are written into `rows` when the kernels' Newton evaluated them at
    /// exactly that pose (what the pose's derivatives need of the legs, not evaluated again),
    /// `None` otherwise.
    ///
    /// # Errors
    /// As [`forward`].
    pub fn solve_near_closed(
        &self,
        readings: &[f64],
        start: &mut Configuration,
        rows: &mut Option<KernelRows>,
    ) -> Result<[f64; 6], KinematicsError> {
        *rows = None;
        if let Some((kernel, kernel_home_sign)) = &self.kernel {
            let mut pose = start.pose;
            let size = 1e3 * self.smallest_size;
            let solved =
                kernel.newton_rows(readings, &mut pose, None, (size, true), (None, Some(rows)));
            if let Some(sign) = solved {
                if same_mode(sign, *kernel_home_sign) {
                    start.pose = pose;
                    return Ok(pose);
                }
            }
            *rows = None;
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
}

/// Are two assembly-mode determinants of the same sign?
fn same_mode(determinant: f64, home: f64) -> bool {
    determinant.is_sign_positive() == home.is_sign_positive()
}
