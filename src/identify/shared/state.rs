//! What a shared problem keeps between its evaluations: each row's warm start and the latest
//! evaluations' values, keyed by the exact bits of the unknowns.

use nalgebra::DMatrix;

use crate::kinematics::inverse::{Joints, Solution};

/// A problem's evaluation state: shared by its clones (a solver clones its problem and refines
/// on the original), which are evaluated one after the other, never at once.
#[derive(Debug, Default)]
pub(super) struct Evaluations {
    /// Per group, each row's joints at its last solved evaluation (`None` before the first):
    /// the warm start of its next inverse-kinematics solve.
    pub(super) seeds: Vec<Vec<Option<Joints>>>,
    /// The latest evaluations, newest first.
    pub(super) recent: Vec<Evaluation>,
    /// Rows whose inverse kinematics were solved so far (the problem's `row_solves`).
    pub(super) row_solves: u64,
}

/// The values of one evaluation, before turn matching: what any evaluation at the same
/// unknowns (bit for bit) returns without solving again.
#[derive(Debug)]
pub(super) struct Evaluation {
    /// The unknowns' bits.
    pub(super) x: Vec<u64>,
    /// One per group.
    pub(super) groups: Vec<GroupValues>,
}

/// One group's rows at one evaluation.
#[derive(Debug)]
pub(super) struct GroupValues {
    /// Each row's platform pose fitted from its target coordinates.
    pub(super) poses: Vec<[f64; 6]>,
    /// Each row's inverse-kinematics solution at its fitted pose.
    pub(super) solutions: Vec<Solution>,
    /// Each row's predicted reading.
    pub(super) predicted: Vec<f64>,
    /// `∂ψ/∂own` (rows × own) and `∂ψ/∂shared` (rows × shared), without the turn matching's
    /// term; `None` until the derivatives are asked for.
    pub(super) derivatives: Option<(DMatrix<f64>, DMatrix<f64>)>,
}

/// The bits of `x`: evaluations are reused only at exactly the same unknowns.
pub(super) fn key(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}
