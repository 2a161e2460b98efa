//! Candidate identification poses: the feasible poses of the workspace's candidate grid
//! ([`crate::workspace::candidates::feasible_poses`]), each with every leg's identification row
//! at the nominal parameters.

use nalgebra::DVector;

use crate::error::Result;
use crate::identify::jacobian::PreparedLeg;
use crate::model::Mechanism;
use crate::workspace::candidates::{feasible_poses, FeasiblePoses};

/// One feasible candidate pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The pose `[x, y, z, roll, pitch, yaw]`.
    pub pose: [f64; 6],
    /// Per leg, the identification row ∂ψ/∂φ (identified parameters) at the nominal values.
    pub rows: Vec<DVector<f64>>,
    /// Smallest serial (type I) measure over the legs.
    pub serial: f64,
    /// Parallel (type II) measure, when defined.
    pub parallel: Option<f64>,
}

/// The candidate pool and what was rejected.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidatePool {
    /// Feasible candidates, in grid order.
    pub candidates: Vec<Candidate>,
    /// Grid points inside the region with its margin.
    pub inside: usize,
    /// Rejected: a leg cannot reach the pose on its home branch.
    pub unreachable: usize,
    /// Rejected: a leg reaches the pose only with a joint beyond its URDF limits.
    pub beyond_limits: usize,
    /// Rejected: too close to a serial singularity.
    pub near_serial: usize,
    /// Rejected: too close to a parallel singularity.
    pub near_parallel: usize,
    /// Grid spacing used, metres.
    pub spacing: f64,
}

/// Builds the candidate pool of `mechanism` with grid spacing `spacing` (metres; default: the
/// model's `workspace.grid`).
///
/// # Errors
/// As [`feasible_poses`]: no spacing given anywhere, or an empty pool.
pub fn candidate_pool(mechanism: &Mechanism, spacing: Option<f64>) -> Result<CandidatePool> {
    let FeasiblePoses {
        poses,
        inside,
        unreachable,
        beyond_limits,
        near_serial,
        near_parallel,
        spacing,
    } = feasible_poses(mechanism, spacing)?;
    let nominal = mechanism.nominal_parameters();
    let prepared: Vec<PreparedLeg<'_>> = mechanism
        .legs
        .iter()
        .zip(&nominal)
        .map(|(leg, phi)| PreparedLeg::new(leg, phi, &leg.identified()))
        .collect();
    let candidates = poses
        .into_iter()
        .map(|feasible| {
            let rows = prepared
                .iter()
                .zip(&feasible.solutions)
                .map(|(leg, solution)| {
                    let mut row = DVector::zeros(leg.columns());
                    leg.reading_and_gradient_at(&feasible.pose, solution, row.as_mut_slice());
                    row
                })
                .collect();
            Candidate {
                pose: feasible.pose,
                rows,
                serial: feasible.serial,
                parallel: feasible.parallel,
            }
        })
        .collect();
    Ok(CandidatePool {
        candidates,
        inside,
        unreachable,
        beyond_limits,
        near_serial,
        near_parallel,
        spacing,
    })
}
