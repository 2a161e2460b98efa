//! Leg inverse kinematics: Newton's method on the closure equations from the home
//! configuration (or warm-started from a previous solution, [`solve_warm`]), staying on the
//! home branch, and the predicted actuator reading.
//!
//! The closure of a leg says that its tip coincides with its platform attachment:
//! `F(q; φ, X) = tip(q; φ) − X·attachment(φ) = 0` on the `closure_dims` first coordinates
//! (x, y in the plane; x, y, z in space). The predicted reading is
//! `ψ = (q_actuated − offset) / gain`.
//!
//! Derivatives never go through the Newton iterations: [`reading_at_solution`] takes one Newton
//! step in the scalar type `T` from the f64 solution, which by the implicit function theorem
//! carries the exact first derivatives `∂q/∂φ = −F_q⁻¹ F_φ` (and `∂q/∂X`).

use std::f64::consts::TAU;

use nalgebra::{Matrix3, Vector3};

use super::chain::{attachment_world, tip_position, ChainFrames};
use super::newton_stop::{beyond_round_off, converged};
use crate::error::KinematicsError;
use crate::model::joint::JointKind;
use crate::model::leg::{LegGeometry, LegModel};
use crate::scalar::{lift, Scalar};

/// Newton iterations per attempt.
const MAX_ITERATIONS: usize = 40;
/// Largest revolute step per Newton iteration, radians (keeps Newton on its branch).
const MAX_ANGLE_STEP: f64 = 0.5;
/// Determinant of the column-normalised closure Jacobian (the sine of the angle between the
/// joints' tip velocities, in the plane) at or below which the leg is at a serial singularity.
/// At a reach limit Newton converges only linearly, and stops with this determinant around
/// 1e-6 to 1e-5 (the joint error is the square root of the residual): the threshold sits above
/// that, while usable poses are far above it (the workspace asks for 0.05 by default).
pub const SINGULAR_DETERMINANT: f64 = 1e-4;
/// Extra Newton iterations spent, at a reach limit, to tell a pose on it (the residual keeps
/// halving) from a pose just beyond it (the residual stalls at the distance to the limit).
const LIMIT_ITERATIONS: usize = 80;

/// Most polishing Newton steps after convergence.
const MAX_POLISH_STEPS: usize = 3;

/// Most moving joints a leg has (as many as closure equations: 3 in space; checked at load).
pub const MAX_JOINTS: usize = 3;

/// A leg's moving joints' values in fixed-size storage: the first `leg.moving.len()` are used,
/// the rest are zero.
pub type Joints = [f64; MAX_JOINTS];

/// A converged inverse-kinematics solution (f64), with what the derivative step needs.
#[derive(Debug, Clone)]
pub struct LegSolution {
    /// The moving joints' values.
    pub q: Vec<f64>,
    /// Inverse of the closure Jacobian ∂F/∂q (top-left `closure_dims` block; rest zero).
    pub closure_inverse: Matrix3<f64>,
    /// Determinant of the column-normalised closure Jacobian (its sign is the branch).
    pub normalised_determinant: f64,
}

/// A [`LegSolution`] in fixed-size storage (a `Copy` value, no heap): what the identification's
/// inner loop passes around.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution {
    /// The moving joints' values (see [`Joints`]).
    pub q: Joints,
    /// The closure error `F` at `q` (tip minus attachment, round-off level): what the
    /// derivative step corrects.
    pub closure: Vector3<f64>,
    /// Inverse of the closure Jacobian ∂F/∂q (top-left `closure_dims` block; rest zero).
    pub closure_inverse: Matrix3<f64>,
    /// Determinant of the column-normalised closure Jacobian (its sign is the branch).
    pub normalised_determinant: f64,
}

impl Solution {
    /// A closed-form solution: the joints `q` closing the leg exactly, with the closure
    /// Jacobian `jacobian`'s inverse (its `dims × dims` block) and `determinant`, its
    /// column-normalised determinant; `None` if the block cannot be inverted.
    pub(crate) fn closed(
        q: Joints,
        jacobian: &Matrix3<f64>,
        dims: usize,
        determinant: f64,
    ) -> Option<Self> {
        Some(Self {
            q,
            closure: Vector3::zeros(),
            closure_inverse: invert(jacobian, dims)?,
            normalised_determinant: determinant,
        })
    }

    /// The same solution with the joints of `leg` in a `Vec`.
    pub fn to_leg_solution(&self, leg: &LegModel) -> LegSolution {
        LegSolution {
            q: self.q[..leg.moving.len()].to_vec(),
            closure_inverse: self.closure_inverse,
            normalised_determinant: self.normalised_determinant,
        }
    }
}

/// The first [`MAX_JOINTS`] values of `values` as [`Joints`] (missing ones zero).
pub fn joints(values: &[f64]) -> Joints {
    let mut q = [0.0; MAX_JOINTS];
    for (slot, &value) in q.iter_mut().zip(values) {
        *slot = value;
    }
    q
}

/// Solves the leg's joints for platform pose `pose` from the leg's home configuration.
///
/// # Errors
/// [`KinematicsError::Unreachable`] if Newton does not converge (also after continuation from
/// the home pose), [`KinematicsError::BranchChange`] if it converges on another working mode,
/// [`KinematicsError::Singular`] at a serial singularity, [`KinematicsError::NonFinite`] for NaN.
pub fn solve_leg(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    pose: &[f64; 6],
    home_pose: &[f64; 6],
) -> Result<LegSolution, KinematicsError> {
    let frames = ChainFrames::new(geometry);
    solve_from_home(leg, geometry, &frames, pose, home_pose).map(|s| s.to_leg_solution(leg))
}

/// As [`solve_leg`], on the geometry's precomputed chain `frames` (`ChainFrames::new(geometry)`),
/// without heap allocation.
///
/// # Errors
/// As [`solve_leg`].
pub fn solve_from_home(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    frames: &ChainFrames<f64>,
    pose: &[f64; 6],
    home_pose: &[f64; 6],
) -> Result<Solution, KinematicsError> {
    let home = joints(&leg.home_joints);
    let attempt = |pose: &[f64; 6], seed: &Joints| {
        let target = attachment_world(pose, &geometry.attachment);
        newton_on(leg, geometry, frames, pose, &target, seed).and_then(|s| on_branch(leg, s))
    };
    let direct = attempt(pose, &home);
    if direct.is_ok() {
        return direct;
    }
    // Continuation from the home pose: small pose steps, each seeded by the previous solution.
    for steps in [4usize, 16, 64] {
        let mut q = home;
        let mut solved = None;
        for step in 1..=steps {
            let t = step as f64 / steps as f64;
            let intermediate: [f64; 6] =
                std::array::from_fn(|i| home_pose[i] + t * (pose[i] - home_pose[i]));
            match attempt(&intermediate, &q) {
                Ok(solution) => {
                    q = solution.q;
                    solved = Some(solution);
                }
                Err(_) => {
                    solved = None;
                    break;
                }
            }
        }
        if let Some(solution) = solved {
            return Ok(solution);
        }
    }
    direct
}

/// Solves the leg's joints for `pose` warm-started from `seed` (the solution of the same pose at
/// nearby parameters, e.g. the previous evaluation of an identification), checking the branch
/// as [`solve_leg`] does; if there is no seed, or Newton from it fails or lands on another
/// working mode, solves from home as [`solve_from_home`] does. The result is the home-branch
/// solution either way: a warm start only saves Newton iterations (revolute joints are
/// unwrapped around the seed, which is the solution's own turn). `target` is the world position
/// of the leg's attachment point at `pose` ([`attachment_world`]).
///
/// # Errors
/// As [`solve_leg`] (the from-home attempt's error).
pub fn solve_warm(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    frames: &ChainFrames<f64>,
    (pose, target): (&[f64; 6], &Vector3<f64>),
    home_pose: &[f64; 6],
    seed: Option<&Joints>,
) -> Result<Solution, KinematicsError> {
    if let Some(seed) = seed {
        let warm =
            newton_on(leg, geometry, frames, pose, target, seed).and_then(|s| on_branch(leg, s));
        if warm.is_ok() {
            return warm;
        }
    }
    solve_from_home(leg, geometry, frames, pose, home_pose)
}

/// Solves the leg's joints for `pose` by Newton from `seed` (e.g. the solution at a nearby
/// pose: a continuation step), and checks the result is on the home branch.
///
/// # Errors
/// As [`solve_leg`].
pub fn solve_leg_from(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    pose: &[f64; 6],
    seed: &[f64],
) -> Result<LegSolution, KinematicsError> {
    newton(leg, geometry, pose, seed).and_then(|s| {
        if leg.on_home_branch(s.normalised_determinant) {
            Ok(s)
        } else {
            Err(branch_change(leg))
        }
    })
}

/// Checks the solution is on the home branch.
fn on_branch(leg: &LegModel, solution: Solution) -> Result<Solution, KinematicsError> {
    if leg.on_home_branch(solution.normalised_determinant) {
        Ok(solution)
    } else {
        Err(branch_change(leg))
    }
}

fn branch_change(leg: &LegModel) -> KinematicsError {
    KinematicsError::BranchChange {
        leg: leg.name.clone(),
    }
}

/// Newton's method on the closure equations from `seed`; revolute joints are unwrapped into the
/// 2π window centred on the seed. No branch check.
///
/// # Errors
/// As [`solve_leg`], except `BranchChange`.
pub fn newton(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    pose: &[f64; 6],
    seed: &[f64],
) -> Result<LegSolution, KinematicsError> {
    let frames = ChainFrames::new(geometry);
    if !seed.iter().all(|v| v.is_finite()) {
        return Err(not_finite(leg, geometry, pose, seed));
    }
    let target = attachment_world(pose, &geometry.attachment);
    newton_on(leg, geometry, &frames, pose, &target, &joints(seed)).map(|s| s.to_leg_solution(leg))
}

/// [`newton`] on the geometry's precomputed chain `frames`, in fixed-size storage; `target` is
/// the world position of the attachment point at `pose`.
fn newton_on(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    frames: &ChainFrames<f64>,
    pose: &[f64; 6],
    target: &Vector3<f64>,
    seed: &Joints,
) -> Result<Solution, KinematicsError> {
    let dims = leg.closure_dims;
    let moving = leg.moving.len();
    if !target.iter().chain(&seed[..moving]).all(|v| v.is_finite()) {
        return Err(not_finite(leg, geometry, pose, &seed[..moving]));
    }
    let tolerance = 1e-13 * (1.0 + target.norm());
    let mut q = *seed;
    let mut residual = f64::INFINITY;
    let mut polishes = 0;
    for iteration in 0..=MAX_ITERATIONS {
        let (tip, jacobian) = frames.tip_and_jacobian(leg, &q[..moving]);
        let closure = closure_error(&tip, target, dims);
        let previous = residual;
        residual = closure.norm();
        if !residual.is_finite() {
            return Err(not_finite(leg, geometry, pose, &q[..moving]));
        }
        // Converged: tiny residual, or round-off floor reached after a tiny improvement.
        if converged(residual, previous, tolerance) {
            let determinant = normalised_determinant(&jacobian, dims);
            if determinant.abs() <= SINGULAR_DETERMINANT {
                return Err(at_reach_limit(leg, frames, target, tolerance, q));
            }
            // Polish: Newton steps until the step is at round-off level (a few units in the
            // last place of the joints), so that the solution — and the derivatives taken at
            // it — does not depend on where Newton started (home, a continuation step or a
            // warm start) beyond round-off. Converging quadratically, one step gets there.
            // The closure Jacobian's inverse, for the polishing step and for the solution.
            let inverse = invert(&jacobian, dims);
            if polishes < MAX_POLISH_STEPS && iteration < MAX_ITERATIONS {
                if let Some(step) = inverse.map(|inverse| limited_step(leg, &inverse, &closure)) {
                    if beyond_round_off(&q[..moving], step.as_slice()) {
                        for (value, delta) in q[..moving].iter_mut().zip(step.iter()) {
                            *value += delta;
                        }
                        polishes += 1;
                        continue;
                    }
                }
            }
            return finish(leg, q, seed, &closure, inverse, determinant);
        }
        if iteration == MAX_ITERATIONS {
            break;
        }
        let Some(step) = newton_step(leg, &jacobian, &closure) else {
            return Err(KinematicsError::Singular {
                leg: leg.name.clone(),
            });
        };
        for (value, delta) in q[..moving].iter_mut().zip(step.iter()) {
            *value += delta;
        }
    }
    Err(KinematicsError::Unreachable {
        leg: leg.name.clone(),
        residual,
        iterations: MAX_ITERATIONS,
    })
}

/// A non-finite number appeared: [`KinematicsError::NonFinite`] if an input is NaN or infinite,
/// [`KinematicsError::Overflow`] (with the largest magnitude) if every input is finite.
fn not_finite(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    pose: &[f64; 6],
    joints: &[f64],
) -> KinematicsError {
    let inputs = pose
        .iter()
        .chain(joints)
        .chain(geometry.origins.iter().flatten())
        .chain(&geometry.attachment)
        .chain([&geometry.gain, &geometry.offset]);
    let mut largest = 0.0f64;
    for value in inputs {
        if !value.is_finite() {
            return KinematicsError::NonFinite {
                leg: leg.name.clone(),
            };
        }
        largest = largest.max(value.abs());
    }
    KinematicsError::Overflow {
        leg: leg.name.clone(),
        largest,
    }
}

/// The Newton step `−F_q⁻¹ F`, shortened so that no revolute joint turns more than
/// [`MAX_ANGLE_STEP`]; `None` if the closure Jacobian is singular.
fn newton_step(
    leg: &LegModel,
    jacobian: &Matrix3<f64>,
    closure: &Vector3<f64>,
) -> Option<Vector3<f64>> {
    let inverse = invert(jacobian, leg.closure_dims)?;
    Some(limited_step(leg, &inverse, closure))
}

/// The Newton step `−inverse · F`, shortened as [`newton_step`] says.
fn limited_step(leg: &LegModel, inverse: &Matrix3<f64>, closure: &Vector3<f64>) -> Vector3<f64> {
    let step = -(inverse * closure);
    let largest_angle = leg
        .moving
        .iter()
        .enumerate()
        .filter(|(_, &j)| leg.joints[j].kind == JointKind::Revolute)
        .map(|(i, _)| step[i].abs())
        .fold(0.0, f64::max);
    // Scaled by 1 (exactly the same step) unless an angle would move by more than the limit.
    step * (MAX_ANGLE_STEP / largest_angle).min(1.0)
}

/// Newton stopped at a (near-)singular configuration `q`: the pose is on the leg's reach limit
/// (a serial singularity) or just beyond it. Newton goes on: on the limit the residual keeps
/// shrinking below `tolerance`; beyond it, it stalls at the distance to the limit.
fn at_reach_limit(
    leg: &LegModel,
    frames: &ChainFrames<f64>,
    target: &Vector3<f64>,
    tolerance: f64,
    mut q: Joints,
) -> KinematicsError {
    let moving = leg.moving.len();
    let mut smallest = f64::INFINITY;
    for _ in 0..LIMIT_ITERATIONS {
        let (tip, jacobian) = frames.tip_and_jacobian(leg, &q[..moving]);
        let closure = closure_error(&tip, target, leg.closure_dims);
        let residual = closure.norm();
        if !residual.is_finite() {
            break;
        }
        smallest = smallest.min(residual);
        if smallest <= tolerance {
            break;
        }
        let Some(step) = newton_step(leg, &jacobian, &closure) else {
            break;
        };
        for (value, delta) in q[..moving].iter_mut().zip(step.iter()) {
            *value += delta;
        }
    }
    if smallest <= tolerance {
        KinematicsError::Singular {
            leg: leg.name.clone(),
        }
    } else {
        KinematicsError::Unreachable {
            leg: leg.name.clone(),
            residual: smallest,
            iterations: MAX_ITERATIONS + LIMIT_ITERATIONS,
        }
    }
}

/// Unwraps revolute joints around the seed and packages the solution with the inverse of its
/// closure Jacobian (`None`: singular; its normalised determinant is above
/// [`SINGULAR_DETERMINANT`]).
fn finish(
    leg: &LegModel,
    mut q: Joints,
    seed: &Joints,
    closure: &Vector3<f64>,
    closure_inverse: Option<Matrix3<f64>>,
    normalised_determinant: f64,
) -> Result<Solution, KinematicsError> {
    for (i, &j) in leg.moving.iter().enumerate() {
        if leg.joints[j].kind == JointKind::Revolute {
            // Whole turns only: a joint already in the window keeps its exact value.
            let difference = q[i] - seed[i];
            let turns = ((difference - wrap_angle(difference)) / TAU).round();
            if turns != 0.0 {
                q[i] -= turns * TAU;
            }
        }
    }
    let Some(closure_inverse) = closure_inverse else {
        return Err(KinematicsError::Singular {
            leg: leg.name.clone(),
        });
    };
    Ok(Solution {
        q,
        closure: *closure,
        closure_inverse,
        normalised_determinant,
    })
}

/// The predicted actuator reading at a converged solution, in scalar `T`: one Newton step in
/// `T` (exact value, exact first derivatives through the implicit function theorem).
pub fn reading_at_solution<T: Scalar>(
    leg: &LegModel,
    geometry: &LegGeometry<T>,
    pose: &[T; 6],
    solution: &LegSolution,
) -> T {
    let q = lifted::<T>(&solution.q);
    let moving = solution.q.len().min(MAX_JOINTS);
    let tip = tip_position(leg, geometry, &q[..moving]);
    let target = attachment_world(pose, &geometry.attachment);
    newton_reading(leg, &q, &tip, &target, &solution.closure_inverse, geometry)
}

/// As [`reading_at_solution`], on precomputed chain `frames` (in `T`) and the world position
/// `target` of the leg's attachment point (in `T`), for the actuator of `geometry`.
pub fn reading_at<T: Scalar>(
    leg: &LegModel,
    frames: &ChainFrames<T>,
    actuator: &LegGeometry<T>,
    target: &Vector3<T>,
    solution: &Solution,
) -> T {
    let tip = frames.tip(leg, &solution.q[..leg.moving.len()]);
    reading_at_tip(leg, &tip, actuator, target, solution)
}

/// As [`reading_at`], from the tip position `tip` (in `T`) of the chain at the solution's joints.
pub fn reading_at_tip<T: Scalar>(
    leg: &LegModel,
    tip: &Vector3<T>,
    actuator: &LegGeometry<T>,
    target: &Vector3<T>,
    solution: &Solution,
) -> T {
    let q = lifted::<T>(&solution.q);
    newton_reading(leg, &q, tip, target, &solution.closure_inverse, actuator)
}

/// The predicted reading (f64) at a converged solution, from the closure error it carries (no
/// chain pass): the value of [`reading_at`] in f64.
pub fn reading_value(leg: &LegModel, actuator: &LegGeometry<f64>, solution: &Solution) -> f64 {
    let q = &solution.q;
    let mut actuated = q[leg.actuated];
    for k in 0..leg.closure_dims {
        actuated -= solution.closure[k] * solution.closure_inverse[(leg.actuated, k)];
    }
    (actuated - actuator.offset) / actuator.gain
}

/// The joints lifted into `T` (at most [`MAX_JOINTS`]; the rest zero).
fn lifted<T: Scalar>(values: &[f64]) -> [T; MAX_JOINTS] {
    let mut joints = [lift::<T>(0.0); MAX_JOINTS];
    for (joint, &value) in joints.iter_mut().zip(values) {
        *joint = lift(value);
    }
    joints
}

/// The reading after one Newton step in `T` from the f64 joints `q`: the actuated joint
/// corrected by `−(F_q⁻¹ F)_actuated`, through the actuator model `(q − offset) / gain`.
fn newton_reading<T: Scalar>(
    leg: &LegModel,
    q: &[T; MAX_JOINTS],
    tip: &Vector3<T>,
    target: &Vector3<T>,
    closure_inverse: &Matrix3<f64>,
    actuator: &LegGeometry<T>,
) -> T {
    let mut actuated = q[leg.actuated];
    for k in 0..leg.closure_dims {
        let coefficient = closure_inverse[(leg.actuated, k)];
        actuated -= (tip[k] - target[k]) * lift::<T>(coefficient);
    }
    (actuated - actuator.offset) / actuator.gain
}

/// The predicted actuator reading for parameters `phi` (all the leg's parameters) and a pose.
///
/// # Errors
/// As [`solve_leg`].
pub fn predict_reading<T: Scalar>(
    leg: &LegModel,
    phi: &[T],
    pose: &[T; 6],
    home_pose: &[f64; 6],
) -> Result<T, KinematicsError> {
    let geometry = leg.geometry(phi);
    let values: Vec<f64> = phi.iter().map(|v| v.re()).collect();
    let pose_values = pose.map(|v| v.re());
    let solution = solve_leg(leg, &leg.geometry(&values), &pose_values, home_pose)?;
    Ok(reading_at_solution(leg, &geometry, pose, &solution))
}

/// Closure error on the first `dims` coordinates.
fn closure_error(tip: &Vector3<f64>, target: &Vector3<f64>, dims: usize) -> Vector3<f64> {
    let mut error = tip - target;
    for k in dims..3 {
        error[k] = 0.0;
    }
    error
}

/// Inverse of the top-left `dims × dims` block (zero elsewhere), or None if singular.
#[inline]
pub(crate) fn invert(jacobian: &Matrix3<f64>, dims: usize) -> Option<Matrix3<f64>> {
    let mut inverse = Matrix3::zeros();
    match dims {
        2 => {
            let block = jacobian
                .fixed_view::<2, 2>(0, 0)
                .into_owned()
                .try_inverse()?;
            inverse.fixed_view_mut::<2, 2>(0, 0).copy_from(&block);
        }
        _ => inverse = jacobian.try_inverse()?,
    }
    inverse.iter().all(|v| v.is_finite()).then_some(inverse)
}

/// Determinant of the `dims × dims` block with unit-norm columns (scale-free, in [−1, 1]), as
/// the determinant of that block completed by the identity (no heap).
#[inline]
pub(crate) fn normalised_determinant(jacobian: &Matrix3<f64>, dims: usize) -> f64 {
    let mut block = Matrix3::identity();
    for c in 0..dims {
        // A zero column stays zero (0 divided by the smallest positive number).
        let norm = (0..dims)
            .map(|r| jacobian[(r, c)] * jacobian[(r, c)])
            .sum::<f64>()
            .sqrt()
            .max(f64::MIN_POSITIVE);
        for r in 0..dims {
            block[(r, c)] = jacobian[(r, c)] / norm;
        }
    }
    block.determinant()
}

/// Wraps an angle into (−π, π].
pub fn wrap_angle(angle: f64) -> f64 {
    // Already in the window (well inside it, away from the rounding at ±π): the same value
    // as below (`angle − 0`, a zero of either sign made +0), without the call to `round`.
    if angle.abs() < 3.0 {
        return angle + 0.0;
    }
    let two_pi = std::f64::consts::TAU;
    let wrapped = angle - two_pi * (angle / two_pi).round();
    if wrapped <= -std::f64::consts::PI {
        wrapped + two_pi
    } else {
        wrapped
    }
}
