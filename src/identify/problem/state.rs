//! What an [`IdentificationProblem`](super::IdentificationProblem) keeps between its
//! evaluations: every block's last solution (the warm start of its next solve) and the latest
//! evaluations' values, keyed by the exact bits of the unknowns.

use nalgebra::{Matrix3, Vector3};

use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::inverse::{joints, Joints, Solution};
use crate::model::leg::LegModel;

/// Largest problem (in blocks) whose inverse-kinematics solutions (and fitted poses) are kept
/// with its latest evaluations (128 bytes a row, 176 through an instrument), so that a
/// Jacobian at any kept evaluation needs the derivative passes only; a larger problem has that
/// only at its last solved evaluation (from its seeds, [`Evaluations::solved`]) and solves an
/// older one again (warm-started).
pub(super) const KEPT_SOLUTION_ROWS: usize = 65_536;

/// A problem's evaluation state.
#[derive(Debug)]
pub(super) struct Evaluations<'a> {
    /// Each block's solution at its last solved evaluation, [`Seeds::stride`] values a block
    /// (NaN before the first): the warm start of its next inverse-kinematics solve, and what
    /// a derivative pass needs at that evaluation's unknowns ([`Evaluations::solved`]).
    pub(super) seeds: Seeds,
    /// The unknowns' bits of the evaluation the seeds are the solutions of (empty when none,
    /// or when a solve failed part-way): a Jacobian asked for there needs the derivative
    /// passes only, even for a problem too large to keep its full solutions.
    pub(super) solved: Vec<u64>,
    /// The latest evaluations, newest first.
    pub(super) recent: Vec<Evaluation<'a>>,
    /// Rows whose inverse kinematics were solved so far ([`IdentificationProblem::row_solves`]).
    pub(super) row_solves: u64,
}

/// What is kept of every block's last inverse-kinematics solution, flat: its moving joints
/// (the next warm start), then the actuated joint's row of the closure Jacobian's inverse
/// (its `closure_dims` first values), which is all a derivative pass takes from a solution
/// besides the joints. 32 bytes a row for a planar leg of two moving joints.
#[derive(Debug)]
pub(super) struct Seeds {
    pub(super) values: Vec<f64>,
    /// Values a block: the largest `moving + closure_dims` of the problem's legs.
    pub(super) stride: usize,
}

/// One block's seed within [`Seeds::values`].
pub(super) fn seed_joints(seed: &[f64], leg: &LegModel) -> Option<Joints> {
    (!seed[0].is_nan()).then(|| joints(&seed[..leg.moving.len()]))
}

/// Stores `solution` as block's seed.
pub(super) fn store_seed(seed: &mut [f64], leg: &LegModel, solution: &Solution) {
    let moving = leg.moving.len();
    seed[..moving].copy_from_slice(&solution.q[..moving]);
    for k in 0..leg.closure_dims {
        seed[moving + k] = solution.closure_inverse[(leg.actuated, k)];
    }
}

/// A solution for the derivative passes from a block's seed: the joints and the actuated row
/// of the closure inverse; its closure error and the other rows are zero (not read by them).
pub(super) fn seed_solution(seed: &[f64], leg: &LegModel) -> Solution {
    let moving = leg.moving.len();
    let mut closure_inverse = Matrix3::zeros();
    for k in 0..leg.closure_dims {
        closure_inverse[(leg.actuated, k)] = seed[moving + k];
    }
    Solution {
        q: joints(&seed[..moving]),
        closure: Vector3::zeros(),
        closure_inverse,
        normalised_determinant: 0.0,
    }
}

/// The values of one evaluation, before turn matching and row weights: what any evaluation
/// at the same unknowns (bit for bit) returns without solving again.
#[derive(Debug)]
pub(super) struct Evaluation<'a> {
    /// The unknowns' bits.
    pub(super) x: Vec<u64>,
    /// Each slot's leg prepared at these unknowns: with its derivative passes once the
    /// gradients were asked for (a Jacobian at a kept evaluation builds only those).
    pub(super) prepared: Vec<PreparedLeg<'a>>,
    /// Each block's inverse-kinematics solution (empty above [`KEPT_SOLUTION_ROWS`]).
    pub(super) solutions: Vec<Solution>,
    /// Each block's platform pose fitted from its targets (through an instrument, up to
    /// [`KEPT_SOLUTION_ROWS`] blocks; else empty).
    pub(super) poses: Vec<[f64; 6]>,
    /// Each block's predicted reading.
    pub(super) predicted: Vec<f64>,
    /// Each block's gradient with respect to its slot's identified parameters, then to the
    /// identified shared parameters, [`IdentificationProblem::gradient_stride`] values a block;
    /// empty until a Jacobian is asked for.
    pub(super) gradients: Vec<f64>,
}

impl Evaluations<'_> {
    /// The state before the first evaluation of a problem of `blocks` blocks: one seed of
    /// `stride` values per block, NaN (no warm start yet).
    pub(super) fn new(blocks: usize, stride: usize) -> Self {
        Self {
            seeds: Seeds {
                values: vec![f64::NAN; blocks * stride],
                stride,
            },
            solved: Vec::new(),
            recent: Vec::new(),
            row_solves: 0,
        }
    }
}

/// Frees the gradients of the kept evaluations (before the gradients of another one are
/// computed).
pub(super) fn release_older_gradients(state: &mut Evaluations<'_>) {
    for older in &mut state.recent {
        older.gradients = Vec::new();
    }
}
