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

/// The candidate pool and what was rejected: the feasible poses as [`Candidate`]s.
pub type CandidatePool = FeasiblePoses<Candidate>;

/// Builds the candidate pool of `mechanism` with grid spacing `spacing` (metres; default: the
/// model's `workspace.grid`).
///
/// # Errors
/// As [`feasible_poses`]: no spacing given anywhere, or an empty pool.
pub fn candidate_pool(mechanism: &Mechanism, spacing: Option<f64>) -> Result<CandidatePool> {
    let feasible = feasible_poses(mechanism, spacing)?;
    let nominal = mechanism.nominal_parameters();
    let prepared: Vec<PreparedLeg<'_>> = mechanism
        .legs
        .iter()
        .zip(&nominal)
        .map(|(leg, phi)| PreparedLeg::new(leg, phi, &leg.identified()))
        .collect();
    Ok(feasible.map(|pose| {
        let rows = prepared
            .iter()
            .zip(&pose.solutions)
            .map(|(leg, solution)| {
                let mut row = DVector::zeros(leg.columns());
                leg.reading_and_gradient_at(&pose.pose, solution, row.as_mut_slice());
                row
            })
            .collect();
        Candidate {
            pose: pose.pose,
            rows,
            serial: pose.serial,
            parallel: pose.parallel,
        }
    }))
}
