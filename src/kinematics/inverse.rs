//! Leg inverse kinematics: Newton's method on the closure equations from the home
//! configuration, staying on the home branch, and the predicted actuator reading.
//!
//! The closure of a leg says that its tip coincides with its platform attachment:
//! `F(q; φ, X) = tip(q; φ) − X·attachment(φ) = 0` on the `closure_dims` first coordinates
//! (x, y in the plane; x, y, z in space). The predicted reading is
//! `ψ = (q_actuated − offset) / gain`.
//!
//! Derivatives never go through the Newton iterations: [`reading_at_solution`] takes one Newton
//! step in the scalar type `T` from the f64 solution, which by the implicit function theorem
//! carries the exact first derivatives `∂q/∂φ = −F_q⁻¹ F_φ` (and `∂q/∂X`).

use nalgebra::{Matrix3, Vector3};

use super::chain::{attachment_world, tip_and_jacobian, tip_position};
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
    let direct = newton(leg, geometry, pose, &leg.home_joints).and_then(|s| on_branch(leg, s));
    if direct.is_ok() {
        return direct;
    }
    // Continuation from the home pose: small pose steps, each seeded by the previous solution.
    for steps in [4usize, 16, 64] {
        let mut q = leg.home_joints.clone();
        let mut solved = None;
        for step in 1..=steps {
            let t = step as f64 / steps as f64;
            let intermediate: [f64; 6] =
                std::array::from_fn(|i| home_pose[i] + t * (pose[i] - home_pose[i]));
            match newton(leg, geometry, &intermediate, &q).and_then(|s| on_branch(leg, s)) {
                Ok(solution) => {
                    q.clone_from(&solution.q);
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
    newton(leg, geometry, pose, seed).and_then(|s| on_branch(leg, s))
}

/// Checks the solution is on the home branch.
fn on_branch(leg: &LegModel, solution: LegSolution) -> Result<LegSolution, KinematicsError> {
    if solution.normalised_determinant * leg.branch_sign > 0.0 {
        Ok(solution)
    } else {
        Err(KinematicsError::BranchChange {
            leg: leg.name.clone(),
        })
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
    let dims = leg.closure_dims;
    let target = attachment_world(pose, &geometry.attachment);
    if !target.iter().all(|v| v.is_finite()) || !seed.iter().all(|v| v.is_finite()) {
        return Err(not_finite(leg, geometry, pose, seed));
    }
    let tolerance = 1e-13 * (1.0 + target.norm());
    let mut q = seed.to_vec();
    let mut residual = f64::INFINITY;
    for iteration in 0..=MAX_ITERATIONS {
        let (tip, jacobian) = tip_and_jacobian(leg, geometry, &q);
        let closure = closure_error(&tip, &target, dims);
        let previous = residual;
        residual = closure.norm();
        if !residual.is_finite() {
            return Err(not_finite(leg, geometry, pose, &q));
        }
        // Converged: tiny residual, or round-off floor reached after a tiny improvement.
        let stalled = residual < 1e3 * tolerance && residual >= 0.5 * previous;
        if residual <= tolerance || stalled {
            let determinant = normalised_determinant(&jacobian, dims);
            if determinant.abs() <= SINGULAR_DETERMINANT {
                return Err(at_reach_limit(leg, geometry, &target, tolerance, q));
            }
            return finish(leg, &mut q, seed, &jacobian, determinant);
        }
        if iteration == MAX_ITERATIONS {
            break;
        }
        let Some(step) = newton_step(leg, &jacobian, &closure) else {
            return Err(KinematicsError::Singular {
                leg: leg.name.clone(),
            });
        };
        for (value, delta) in q.iter_mut().zip(step.iter()) {
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
    let mut step = -(inverse * closure);
    let largest_angle = leg
        .moving
        .iter()
        .enumerate()
        .filter(|(_, &j)| leg.joints[j].kind == JointKind::Revolute)
        .map(|(i, _)| step[i].abs())
        .fold(0.0, f64::max);
    if largest_angle > MAX_ANGLE_STEP {
        step *= MAX_ANGLE_STEP / largest_angle;
    }
    Some(step)
}

/// Newton stopped at a (near-)singular configuration `q`: the pose is on the leg's reach limit
/// (a serial singularity) or just beyond it. Newton goes on: on the limit the residual keeps
/// shrinking below `tolerance`; beyond it, it stalls at the distance to the limit.
fn at_reach_limit(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    target: &Vector3<f64>,
    tolerance: f64,
    mut q: Vec<f64>,
) -> KinematicsError {
    let mut smallest = f64::INFINITY;
    for _ in 0..LIMIT_ITERATIONS {
        let (tip, jacobian) = tip_and_jacobian(leg, geometry, &q);
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
        for (value, delta) in q.iter_mut().zip(step.iter()) {
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

/// Unwraps revolute joints around the seed and packages the solution (its normalised
/// determinant is above [`SINGULAR_DETERMINANT`]).
fn finish(
    leg: &LegModel,
    q: &mut [f64],
    seed: &[f64],
    jacobian: &Matrix3<f64>,
    normalised_determinant: f64,
) -> Result<LegSolution, KinematicsError> {
    for (i, &j) in leg.moving.iter().enumerate() {
        if leg.joints[j].kind == JointKind::Revolute {
            q[i] = seed[i] + wrap_angle(q[i] - seed[i]);
        }
    }
    let Some(closure_inverse) = invert(jacobian, leg.closure_dims) else {
        return Err(KinematicsError::Singular {
            leg: leg.name.clone(),
        });
    };
    Ok(LegSolution {
        q: q.to_vec(),
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
    // A leg has as many moving joints as closure equations: at most 3 (checked at load).
    let mut joints = [lift::<T>(0.0); 3];
    for (joint, &value) in joints.iter_mut().zip(&solution.q) {
        *joint = lift(value);
    }
    let q = &joints[..solution.q.len()];
    let tip = tip_position(leg, geometry, q);
    let target = attachment_world(pose, &geometry.attachment);
    let mut actuated = q[leg.actuated];
    for k in 0..leg.closure_dims {
        let coefficient = solution.closure_inverse[(leg.actuated, k)];
        actuated -= (tip[k] - target[k]) * lift::<T>(coefficient);
    }
    (actuated - geometry.offset) / geometry.gain
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
fn invert(jacobian: &Matrix3<f64>, dims: usize) -> Option<Matrix3<f64>> {
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

/// Determinant of the `dims × dims` block with unit-norm columns (scale-free, in [−1, 1]).
fn normalised_determinant(jacobian: &Matrix3<f64>, dims: usize) -> f64 {
    let mut block = nalgebra::DMatrix::from_fn(dims, dims, |r, c| jacobian[(r, c)]);
    for mut column in block.column_iter_mut() {
        let norm = column.norm();
        if norm > 0.0 {
            column /= norm;
        }
    }
    block.determinant()
}

/// Wraps an angle into (−π, π].
pub fn wrap_angle(angle: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let wrapped = angle - two_pi * (angle / two_pi).round();
    if wrapped <= -std::f64::consts::PI {
        wrapped + two_pi
    } else {
        wrapped
    }
}
