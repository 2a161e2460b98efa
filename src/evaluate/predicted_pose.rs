//! How well a calibration from measured poses (no instrument: the 5R, the 3-RPR, the hexapod
//! from a tracker's poses) knows where its end effector goes: the fit's covariance propagated
//! to the position over the workspace.
//!
//! At a grid pose `P` the calibrated model commands the readings `q` of its inverse kinematics;
//! the real mechanism, its parameters off by `δφ`, goes where every leg's reading is still `q`:
//! `∂ψ/∂P δP + ∂ψ/∂φ δφ = 0`, so `δP = −(∂ψ/∂P)⁺ ∂ψ/∂φ δφ` over the measured pose coordinates
//! (one row per leg; the pseudo-inverse when the legs outnumber them). Both derivatives are the
//! identification's dual numbers (`∂ψ/∂φ` the Jacobian of a problem whose blocks are the grid
//! poses, `∂ψ/∂P` the pose gradients its statistics use). The position's covariance is `G C
//! Gᵀ` over its coordinates (`C` the fit's covariance), its σ the square root of the trace.

use nalgebra::{DMatrix, DVector};

use super::accuracy::map_grid;
use crate::identify::problem::IdentificationProblem;
use crate::identify::result::PredictedPosition;
use crate::identify::statistics::row_loadings;
use crate::kinematics::inverse::predict_reading;
use crate::measure::ResidualBlock;
use crate::model::mechanism::MeasurementNoise;
use crate::model::Mechanism;

/// Fraction of the workspace region the prediction covers (as the accuracy map's default).
const SCALE: f64 = 0.95;

/// The predicted σ of the end effector's position over the workspace (`workspace.grid`, 0.95
/// of the region, at home height) of the model at `params` (every leg's parameters), whose
/// identified parameters (the identified legs in model order, each one's identified parameters
/// in order) have `covariance`. `None` with an instrument, without a grid or a measured
/// position coordinate, with a covariance of another size, or when no grid pose is reached.
pub fn predicted_pose_sigma(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    covariance: &DMatrix<f64>,
) -> Option<PredictedPosition> {
    let grid = map_grid(mechanism, mechanism.workspace.grid?, SCALE).ok()?;
    let sigmas = position_sigmas(mechanism, params, covariance, &grid)?;
    let reached: Vec<f64> = sigmas.into_iter().flatten().collect();
    if reached.is_empty() {
        return None;
    }
    let rms = (reached.iter().map(|s| s * s).sum::<f64>() / reached.len() as f64).sqrt();
    Some(PredictedPosition {
        target: "end effector".into(),
        points: reached.len(),
        rms,
        max: reached.iter().copied().fold(0.0, f64::max),
        tolerance: None,
    })
}

/// The predicted σ of the end effector's position at each of `targets` (`None` where a leg
/// cannot reach it), as [`predicted_pose_sigma`] takes them; `None` with an instrument,
/// without a measured position coordinate, or with a covariance of another size.
pub fn position_sigmas(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    covariance: &DMatrix<f64>,
    targets: &[[f64; 6]],
) -> Option<Vec<Option<f64>>> {
    if mechanism.instrument.is_some() {
        return None;
    }
    let measured = &mechanism.measured;
    // The measured coordinates that are positions (x, y, z: indices 0 to 2).
    let positions: Vec<usize> = (0..measured.len()).filter(|&k| measured[k] <= 2).collect();
    if positions.is_empty() {
        return None;
    }
    let grid = targets;
    let home = &mechanism.home_pose;
    // The grid poses every leg reaches, a block per leg there (its reading the commanded one).
    let mut poses = Vec::new();
    let mut blocks = Vec::new();
    let mut indices = Vec::new();
    for (index, pose) in grid.iter().enumerate() {
        let readings: Option<Vec<f64>> = (0..mechanism.legs.len())
            .map(|l| predict_reading(&mechanism.legs[l], &params[l], pose, home).ok())
            .collect();
        let Some(readings) = readings else { continue };
        indices.push(index);
        poses.push(*pose);
        blocks.extend((0..mechanism.legs.len()).map(|leg| ResidualBlock {
            leg,
            pose: *pose,
            reading: readings[leg],
            line: None,
        }));
    }
    if poses.is_empty() {
        return Some(vec![None; grid.len()]);
    }
    let every: Vec<usize> = (0..mechanism.legs.len()).collect();
    // Every leg's rows (the pose gradients need them all); the unknowns the identified legs'.
    let problem = IdentificationProblem::new(mechanism, &every, blocks);
    let x = unknowns(&problem, params);
    if covariance.shape() != (x.len(), x.len()) {
        return None;
    }
    let (_, jacobian) = problem.residuals_and_jacobian(&x).ok()?;
    let unit = MeasurementNoise {
        pose: [1.0; 6],
        reading: 0.0,
        scale: 1.0,
    };
    let gradients = row_loadings(&problem, &x, &unit).ok()?;
    let width = mechanism.legs.len();
    let mut sigmas = Vec::with_capacity(poses.len());
    for i in 0..poses.len() {
        // ∂ψ/∂P over the measured coordinates, ∂ψ/∂φ, the legs' rows at this pose.
        let first = i * width;
        let d_pose = DMatrix::from_fn(width, measured.len(), |r, k| {
            gradients.rows[first + r].1[measured[k]]
        });
        let d_params = jacobian.rows(first, width).into_owned();
        let pseudo = d_pose.pseudo_inverse(1e-12).ok()?;
        // δP = −(∂ψ/∂P)⁺ ∂ψ/∂φ δφ; the sign does not reach the σ.
        let moved = pseudo * d_params;
        let position = DMatrix::from_fn(positions.len(), x.len(), |r, j| moved[(positions[r], j)]);
        let variance = (&position * covariance * position.transpose()).trace();
        sigmas.push(variance.max(0.0).sqrt());
    }
    // Back to the targets, `None` where a leg could not reach one.
    let mut all = vec![None; grid.len()];
    for (index, sigma) in indices.into_iter().zip(sigmas) {
        all[index] = Some(sigma);
    }
    Some(all)
}

/// The problem's unknowns at `params` (its slots' identified parameters).
fn unknowns(problem: &IdentificationProblem<'_>, params: &[Vec<f64>]) -> DVector<f64> {
    let mut x = problem.start();
    for slot in problem.slots() {
        for (k, &c) in slot.columns.iter().enumerate() {
            x[slot.offset + k] = params[slot.leg][c];
        }
    }
    x
}
