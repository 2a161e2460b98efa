//! Closed-form leg kernels: the legs whose inverse kinematics legwise solves without Newton's
//! method, recognised once from the chain's joint kinds and geometry (never from the
//! mechanism's name). A leg that matches no pattern exactly keeps the generic chain
//! ([`super::inverse`]); a kernel also hands back to it every pose it cannot solve cleanly
//! (out of reach, near a reach limit), so that refusals are the generic solve's own.
//!
//! A kernel gives the [`Solution`] Newton's method converges to (to round-off) and the
//! actuated joint's value in any scalar, so the identification's dual pass takes the reading's
//! exact derivatives from the same closed form.

use nalgebra::Vector3;

use super::carriage_leg::{CarriageFrame, CarriageLeg};
use super::chain::LazyChainFrames;
use super::distance_leg::{DistanceFrame, DistanceLeg};
use super::dyad::{on_turn_of, Dyad, DyadFrame};
use super::inverse::{joints, solve_warm, Joints, Solution};
use crate::error::KinematicsError;
use crate::model::leg::{LegGeometry, LegModel};
use crate::scalar::Scalar;

/// A recognised closed-form pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LegKernel {
    /// A planar two-revolute dyad reaching a point ([`super::dyad`]).
    Dyad(Dyad),
    /// Revolutes meeting at a base point, then the actuated prismatic joint through it: a
    /// distance ([`super::distance_leg`]).
    Distance(DistanceLeg),
    /// The actuated carriage, then a universal joint and a rod: a square root
    /// ([`super::carriage_leg`]).
    Carriage(CarriageLeg),
}

/// A kernel prepared at one parameter vector, in scalar `T`.
#[derive(Debug, Clone, Copy)]
pub struct PreparedKernel<T> {
    kernel: LegKernel,
    frame: KernelFrame<T>,
}

/// What a kernel precomputes from a parameter vector.
#[derive(Debug, Clone, Copy)]
enum KernelFrame<T> {
    Dyad(DyadFrame<T>),
    Distance(DistanceFrame<T>),
    Carriage(CarriageFrame<T>),
}

impl LegKernel {
    /// The closed-form pattern `leg`'s chain matches exactly, if any.
    pub fn recognise(leg: &LegModel) -> Option<Self> {
        Dyad::recognise(leg)
            .map(Self::Dyad)
            .or_else(|| DistanceLeg::recognise(leg).map(Self::Distance))
            .or_else(|| CarriageLeg::recognise(leg).map(Self::Carriage))
    }

    /// The actuated joint at the world `target` from the frame's numbers `frame` (the value
    /// parts of [`PreparedKernel::frame_scalars`]), on the turn of `solution`, with its partial
    /// derivatives with respect to the frame's eight numbers and the target's three
    /// ([`Dyad::actuated_partials`], [`DistanceLeg::actuated_partials`],
    /// [`CarriageLeg::actuated_partials`]; a planar kernel's partial along z is zero); `None`
    /// where the closed form fails, then the caller takes [`PreparedKernel::reading`] in its
    /// scalar.
    #[inline]
    pub fn actuated_partials(
        &self,
        frame: &[f64; 8],
        target: [f64; 3],
        solution: &Solution,
    ) -> Option<(f64, [f64; 11])> {
        match self {
            LegKernel::Dyad(dyad) => {
                let (value, planar) =
                    dyad.actuated_partials(frame, [target[0], target[1]], solution)?;
                let mut partials = [0.0; 11];
                partials[..10].copy_from_slice(&planar);
                Some((value, partials))
            }
            LegKernel::Distance(leg) => leg.actuated_partials(frame, target),
            LegKernel::Carriage(leg) => leg.actuated_partials(frame, target),
        }
    }

    /// [`PreparedKernel::frame_scalars`] of the kernel prepared at `geometry`, bit for bit,
    /// without what only the f64 solve needs of the frame (a derivative pass's lanes).
    pub fn frame_scalars<T: Scalar>(&self, geometry: &LegGeometry<T>) -> [T; 8] {
        match self {
            Self::Dyad(dyad) => dyad.frame(geometry).scalars(),
            Self::Distance(leg) => leg.frame_scalars(geometry),
            Self::Carriage(leg) => leg.frame_scalars(geometry),
        }
    }

    /// The kernel prepared at `geometry` (the leg's geometry at one parameter vector).
    pub fn prepare<T: Scalar>(&self, geometry: &LegGeometry<T>) -> PreparedKernel<T> {
        let frame = match self {
            Self::Dyad(dyad) => KernelFrame::Dyad(dyad.frame(geometry)),
            Self::Distance(leg) => KernelFrame::Distance(leg.frame(geometry)),
            Self::Carriage(leg) => KernelFrame::Carriage(leg.frame(geometry)),
        };
        PreparedKernel {
            kernel: *self,
            frame,
        }
    }
}

/// Each leg's kernel (`kernels`, one per leg, `None` for a leg without one; missing ones
/// count as `None`) prepared at its geometry (`geometries`, one per leg).
pub(crate) fn prepare_each(
    kernels: &[Option<LegKernel>],
    geometries: &[LegGeometry<f64>],
) -> Vec<Option<PreparedKernel<f64>>> {
    let kernels = kernels.iter().chain(std::iter::repeat(&None));
    (geometries.iter().zip(kernels))
        .map(|(geometry, kernel)| kernel.map(|kernel| kernel.prepare(geometry)))
        .collect()
}

impl PreparedKernel<f64> {
    /// The solution reaching `target` (the world position of the leg's attachment at the
    /// pose), joints in the 2π window centred on `seed`; `None`: left to the generic solve.
    #[inline]
    pub fn solve(&self, target: &Vector3<f64>, seed: &Joints) -> Option<Solution> {
        match (&self.kernel, &self.frame) {
            (LegKernel::Dyad(dyad), KernelFrame::Dyad(frame)) => dyad.solve(frame, target, seed),
            (LegKernel::Distance(leg), KernelFrame::Distance(frame)) => {
                leg.solve(frame, target, seed)
            }
            (LegKernel::Carriage(leg), KernelFrame::Carriage(frame)) => {
                leg.solve(frame, target, seed)
            }
            _ => None,
        }
    }

    /// The actuated joint's value reaching `target` (up to whole turns) and the actuated row
    /// of the closure Jacobian's inverse there, without the passive joints: what a forward
    /// solve needs from a leg. `None` where [`Self::solve`] would leave the pose to the generic
    /// solve.
    #[inline]
    pub fn actuated_row(&self, target: &Vector3<f64>) -> Option<(f64, [f64; 3])> {
        match (&self.kernel, &self.frame) {
            (LegKernel::Dyad(dyad), KernelFrame::Dyad(frame)) => dyad.actuated_row(frame, target),
            (LegKernel::Distance(leg), KernelFrame::Distance(frame)) => {
                leg.actuated_row(frame, target)
            }
            (LegKernel::Carriage(leg), KernelFrame::Carriage(frame)) => {
                leg.actuated_row(frame, target)
            }
            _ => None,
        }
    }
}

impl PreparedKernel<f64> {
    /// For a carriage leg, the sphere its tip is on when its carriage is at `actuated`: the
    /// universal joint's world position and the rod's length ([`CarriageLeg::tip_sphere`]);
    /// `None` for any other kernel.
    pub(crate) fn tip_sphere(&self, actuated: f64) -> Option<([f64; 3], f64)> {
        match (&self.kernel, &self.frame) {
            (LegKernel::Carriage(leg), KernelFrame::Carriage(frame)) => {
                Some(leg.tip_sphere(frame, actuated))
            }
            _ => None,
        }
    }

    /// For a dyad actuated at its base, the circle its tip is on when its actuated joint is
    /// at `actuated`: the elbow's world `(x, y)` and the distal link's length
    /// ([`Dyad::elbow_circle`]); `None` for any other kernel.
    pub(crate) fn tip_circle(&self, actuated: f64) -> Option<([f64; 2], f64)> {
        match (&self.kernel, &self.frame) {
            (LegKernel::Dyad(dyad), KernelFrame::Dyad(frame)) => dyad.elbow_circle(frame, actuated),
            _ => None,
        }
    }
}

/// A leg's inverse kinematics at one parameter vector: its closed-form kernel when its chain
/// has one, the generic chain's Newton solve for every pose the kernel leaves to it (and for
/// every pose of a leg without a kernel). The same solutions either way, to round-off.
#[derive(Debug, Clone)]
pub struct LegInverse<'a> {
    leg: &'a LegModel,
    geometry: &'a LegGeometry<f64>,
    frames: &'a LazyChainFrames,
    kernel: Option<PreparedKernel<f64>>,
}

impl<'a> LegInverse<'a> {
    /// `leg`'s inverse kinematics at `geometry` (its chain `frames`, built on first use), with
    /// the closed-form kernel its chain matches, if any.
    pub fn new(
        leg: &'a LegModel,
        geometry: &'a LegGeometry<f64>,
        frames: &'a LazyChainFrames,
    ) -> Self {
        Self {
            leg,
            geometry,
            frames,
            kernel: LegKernel::recognise(leg).map(|kernel| kernel.prepare(geometry)),
        }
    }

    /// The leg's joints at `pose` (`target`: the world position of its attachment there),
    /// warm-started from `seed` when given: [`solve_warm_through`] its kernel.
    ///
    /// # Errors
    /// As [`solve_warm`]: the leg cannot reach the pose on its home branch.
    pub fn solve_warm(
        &self,
        at: (&[f64; 6], &Vector3<f64>),
        home_pose: &[f64; 6],
        seed: Option<&Joints>,
    ) -> Result<Solution, KinematicsError> {
        let leg = (self.leg, self.geometry, self.frames);
        solve_warm_through(self.kernel.as_ref(), leg, at, home_pose, seed)
    }
}

/// A leg's joints at `pose` (`target`: the world position of its attachment there), warm-started
/// from `seed` when given: the closed form of `kernel` (the leg's, prepared at `geometry`) on
/// the turn of `seed` (of the home joints without one), else [`solve_warm`] on the generic
/// chain (`frames` of `geometry`). Allocates nothing.
///
/// # Errors
/// As [`solve_warm`]: the leg cannot reach the pose on its home branch.
pub fn solve_warm_through(
    kernel: Option<&PreparedKernel<f64>>,
    (leg, geometry, frames): (&LegModel, &LegGeometry<f64>, &LazyChainFrames),
    (pose, target): (&[f64; 6], &Vector3<f64>),
    home_pose: &[f64; 6],
    seed: Option<&Joints>,
) -> Result<Solution, KinematicsError> {
    if let Some(kernel) = kernel {
        let seed = seed.copied().unwrap_or_else(|| joints(&leg.home_joints));
        if let Some(solution) = kernel.solve(target, &seed) {
            return Ok(solution);
        }
    }
    let frames = frames.get(geometry);
    solve_warm(leg, geometry, frames, (pose, target), home_pose, seed)
}

impl LegInverse<'_> {
    /// The actuated joint alone at `target` through the leg's kernel, on the turn of `seed`'s
    /// (of the home joints' without one): the value [`Self::solve_warm`] gives it, without the
    /// passive joints (one arc tangent). `None` for a leg without a kernel, or where the kernel
    /// leaves the pose to the generic solve (then call [`Self::solve_warm`]).
    pub fn actuated(&self, target: &Vector3<f64>, seed: Option<&Joints>) -> Option<f64> {
        let (value, _) = self.kernel.as_ref()?.actuated_row(target)?;
        if !self.leg.actuated_is_revolute() {
            return Some(value);
        }
        let a = self.leg.actuated;
        let seed = seed.map_or_else(|| self.leg.home_joints[a], |seed| seed[a]);
        Some(on_turn_of(value, seed))
    }
}

impl<T: Scalar> PreparedKernel<T> {
    /// The pattern this kernel was prepared from.
    #[inline]
    pub fn kernel(&self) -> LegKernel {
        self.kernel
    }

    /// The numbers the kernel's frame holds (in `T`): the inputs
    /// [`LegKernel::actuated_partials`] differentiates by ([`super::dyad::DyadFrame::scalars`],
    /// [`super::distance_leg::DistanceFrame::scalars`],
    /// [`super::carriage_leg::CarriageFrame::scalars`]).
    #[inline]
    pub fn frame_scalars(&self) -> [T; 8] {
        match &self.frame {
            KernelFrame::Dyad(frame) => frame.scalars(),
            KernelFrame::Distance(frame) => frame.scalars(),
            KernelFrame::Carriage(frame) => frame.scalars(),
        }
    }

    /// The predicted reading `(q_actuated − offset) / gain` at `target` (in `T`), on the turn
    /// of `solution` (the f64 solution of the same pose); `None` if the closed form fails in
    /// `T`'s value part (the caller then takes the generic derivative step).
    #[inline]
    pub fn reading(
        &self,
        actuator: &LegGeometry<T>,
        target: &Vector3<T>,
        solution: &Solution,
    ) -> Option<T> {
        let actuated = match (&self.kernel, &self.frame) {
            (LegKernel::Dyad(dyad), KernelFrame::Dyad(frame)) => {
                dyad.actuated(frame, target, solution)?
            }
            (LegKernel::Distance(leg), KernelFrame::Distance(frame)) => {
                leg.actuated(frame, target)?
            }
            (LegKernel::Carriage(leg), KernelFrame::Carriage(frame)) => {
                leg.actuated(frame, target)?
            }
            _ => return None,
        };
        Some((actuated - actuator.offset) / actuator.gain)
    }
}
