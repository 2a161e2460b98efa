//! The least-squares problem of one leg (divide and conquer) or of several legs stacked
//! (traditional): the same residual blocks, grouped differently. Implements argmin's
//! `Operator` (residuals) and `Jacobian` (dual numbers).
//!
//! Rows may carry weights `w_i` (weighted least squares: each residual and its Jacobian row are
//! multiplied by `√w_i`); a revolute actuator's residual is matched modulo one turn of the
//! joint ([`super::residual::turns`]).

use std::borrow::Cow;
use std::sync::{Arc, Mutex, MutexGuard};

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;

use super::jacobian::PreparedLeg;
use super::residual::{turn_in_reading_units, turns, ResidualBlock};
use crate::error::KinematicsError;
use crate::kinematics::chain::{platform_transform_f64, Transform};
use crate::kinematics::inverse::{joints, Joints, Solution};
use crate::model::leg::LegModel;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;

/// Where one leg's identified parameters sit in the problem's parameter vector.
#[derive(Debug, Clone)]
pub struct LegSlot {
    /// Index of the leg in the mechanism.
    pub leg: usize,
    /// Indices (into the leg's parameters) of the identified parameters.
    pub columns: Vec<usize>,
    /// Offset of the first of them in the problem's parameter vector.
    pub offset: usize,
}

/// A failed residual block: which block, and why. At the starting parameters the caller names
/// the measurement line from [`BlockError::block`] and [`BlockError::source`]; the message of
/// the error itself is for a failure *during* a solve (a solver passes it on): there the trial
/// parameters are at fault, not the data, and the message says so with their values.
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "the solver diverged: at its trial parameters ({parameters}), {location}: {source}; the step \
     left the plausible parameters (the pose is usable at the starting ones): try the \
     Levenberg-Marquardt solver, and if it fails too check the units of the readings (radians, \
     metres)"
)]
pub struct BlockError {
    /// Index of the block in the problem.
    pub block: usize,
    /// The kinematic failure.
    pub source: KinematicsError,
    /// `measurement line N`, or `residual block N` for a pose without a file line.
    pub location: String,
    /// The trial parameter values, `name = value, …`.
    pub parameters: String,
}

/// Least-squares identification problem over a set of residual blocks.
#[derive(Debug, Clone)]
pub struct IdentificationProblem<'a> {
    mechanism: &'a Mechanism,
    slots: Vec<LegSlot>,
    slot_of_leg: Vec<Option<usize>>,
    /// Shared by the problem's clones (a solver clones its problem).
    blocks: Arc<Vec<ResidualBlock>>,
    /// `√w_i` per block, if weighted.
    row_scales: Option<Vec<f64>>,
    /// Each block's platform transform (its pose's trigonometry done once), for problems of at
    /// most [`KEPT_SOLUTION_ROWS`] blocks (96 bytes a row); empty for larger ones, whose rows
    /// compute theirs at each evaluation.
    platforms: Arc<[Transform<f64>]>,
    /// Each block's last inverse-kinematics solution (the warm start of the next evaluation)
    /// and the values of the latest evaluations. Shared by the problem's clones (a solver
    /// clones its problem, and refines the estimate on the original): a problem and its clones
    /// are evaluated one after the other, never at once.
    state: Arc<Mutex<Evaluations>>,
}

/// Rows per task: a problem with more rows is evaluated in parallel (rayon), in chunks of this
/// many rows. The chunks do not depend on the number of threads, and every row's warm start
/// only on that row's own history, so neither do the results.
const ROWS_PER_TASK: usize = 512;

/// Latest evaluations kept (the solvers evaluate the Jacobian where they last evaluated the
/// residuals; the refinement may end on a rejected point after the estimate).
const KEPT_EVALUATIONS: usize = 2;

/// Largest problem (in blocks) whose inverse-kinematics solutions are kept with its latest
/// evaluations (128 bytes a row), so that a Jacobian at any kept evaluation needs the dual
/// passes only; a larger problem has that only at its last solved evaluation (from its
/// seeds, [`Evaluations::solved`]) and solves an older one again (warm-started).
const KEPT_SOLUTION_ROWS: usize = 65_536;

/// A problem's evaluation state.
#[derive(Debug)]
struct Evaluations {
    /// Each block's solution at its last solved evaluation, [`Seeds::stride`] values a block
    /// (NaN before the first): the warm start of its next inverse-kinematics solve, and what
    /// a dual pass needs at that evaluation's unknowns ([`Evaluations::solved`]).
    seeds: Seeds,
    /// The unknowns' bits of the evaluation the seeds are the solutions of (empty when none,
    /// or when a solve failed part-way): a Jacobian asked for there needs the dual passes
    /// only, even for a problem too large to keep its full solutions.
    solved: Vec<u64>,
    /// The latest evaluations, newest first.
    recent: Vec<Evaluation>,
    /// Rows whose inverse kinematics were solved so far ([`IdentificationProblem::row_solves`]).
    row_solves: u64,
}

/// What is kept of every block's last inverse-kinematics solution, flat: its moving joints
/// (the next warm start), then the actuated joint's row of the closure Jacobian's inverse
/// (its `closure_dims` first values), which is all the dual pass takes from a solution
/// besides the joints. 32 bytes a row for a planar leg of two moving joints.
#[derive(Debug)]
struct Seeds {
    values: Vec<f64>,
    /// Values a block: the largest `moving + closure_dims` of the problem's legs.
    stride: usize,
}

/// One block's seed within [`Seeds::values`].
fn seed_joints(seed: &[f64], leg: &LegModel) -> Option<Joints> {
    (!seed[0].is_nan()).then(|| joints(&seed[..leg.moving.len()]))
}

/// Stores `solution` as block's seed.
fn store_seed(seed: &mut [f64], leg: &LegModel, solution: &Solution) {
    let moving = leg.moving.len();
    seed[..moving].copy_from_slice(&solution.q[..moving]);
    for k in 0..leg.closure_dims {
        seed[moving + k] = solution.closure_inverse[(leg.actuated, k)];
    }
}

/// A solution for the dual pass ([`PreparedLeg::reading_and_gradient_on`]) from a block's
/// seed: the joints and the actuated row of the closure inverse; its closure error and the
/// other rows are zero (not read by the dual pass).
fn seed_solution(seed: &[f64], leg: &LegModel) -> Solution {
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
struct Evaluation {
    /// The unknowns' bits.
    x: Vec<u64>,
    /// Each block's inverse-kinematics solution (empty above [`KEPT_SOLUTION_ROWS`]).
    solutions: Vec<Solution>,
    /// Each block's predicted reading.
    predicted: Vec<f64>,
    /// Each block's gradient with respect to its slot's identified parameters, `width` values
    /// a block (the widest slot's count); empty until a Jacobian is asked for.
    gradients: Vec<f64>,
}

impl Evaluations {
    /// The state before the first evaluation of a problem of `blocks` blocks: one seed of
    /// `stride` values per block, NaN (no warm start yet).
    fn new(blocks: usize, stride: usize) -> Self {
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
fn release_older_gradients(state: &mut Evaluations) {
    for older in &mut state.recent {
        older.gradients = Vec::new();
    }
}

/// One task's rows: the chunk's index, its seeds, predicted readings and gradients.
type ChunkOfRows<'c> = (usize, ((&'c mut [f64], &'c mut [f64]), &'c mut [f64]));

/// The bits of `x`: evaluations are reused only at exactly the same unknowns.
fn key(x: &DVector<f64>) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// What turn matching needs of one slot's leg at one parameter vector.
#[derive(Debug, Clone, Copy)]
struct TurnMatch {
    gain: f64,
    /// Position of the gain among the slot's identified columns, if identified.
    gain_column: Option<usize>,
    revolute: bool,
}

impl<'a> IdentificationProblem<'a> {
    /// A problem identifying the legs `legs` from `blocks` (blocks of other legs are ignored).
    pub fn new(mechanism: &'a Mechanism, legs: &[usize], blocks: Vec<ResidualBlock>) -> Self {
        let mut slots = Vec::new();
        let mut slot_of_leg = vec![None; mechanism.legs.len()];
        let mut offset = 0;
        for &leg in legs {
            let columns = mechanism.legs[leg].identified();
            slot_of_leg[leg] = Some(slots.len());
            let count = columns.len();
            slots.push(LegSlot {
                leg,
                columns,
                offset,
            });
            offset += count;
        }
        // Filtered in place and moved into the `Arc` (a large problem's blocks are tens of
        // megabytes: no copy).
        let mut blocks = blocks;
        blocks.retain(|b| slot_of_leg[b.leg].is_some());
        blocks.shrink_to_fit();
        let blocks = Arc::new(blocks);
        // Seeds of the widest leg's moving joints and closure-inverse row.
        let stride = slots
            .iter()
            .map(|slot| {
                let leg = &mechanism.legs[slot.leg];
                leg.moving.len() + leg.closure_dims
            })
            .max()
            .unwrap_or(1);
        let state = Evaluations::new(blocks.len(), stride);
        Self {
            blocks: blocks.clone(),
            mechanism,
            slots,
            slot_of_leg,
            row_scales: None,
            platforms: if blocks.len() <= KEPT_SOLUTION_ROWS {
                blocks
                    .iter()
                    .map(|b| platform_transform_f64(&b.pose))
                    .collect()
            } else {
                Arc::from(Vec::new())
            },
            state: Arc::new(Mutex::new(state)),
        }
    }

    /// The same problem with row weights `weights` (one per block, in row order, finite and
    /// non-negative): residual `i` and its Jacobian row are multiplied by `√weights[i]`.
    /// A missing weight counts as 1.
    pub fn with_weights(mut self, weights: &[f64]) -> Self {
        self.row_scales = Some(
            (0..self.blocks.len())
                .map(|i| weights.get(i).copied().unwrap_or(1.0).max(0.0).sqrt())
                .collect(),
        );
        self
    }

    /// The same problem without row weights.
    pub fn unweighted(&self) -> Self {
        Self {
            row_scales: None,
            ..self.clone()
        }
    }

    /// Whether the problem is weighted ([`Self::with_weights`]).
    pub fn is_weighted(&self) -> bool {
        self.row_scales.is_some()
    }

    /// The same legs without the blocks at rows `rows` (and without weights).
    pub fn without_rows(&self, rows: &[usize]) -> Self {
        let legs: Vec<usize> = self.slots.iter().map(|s| s.leg).collect();
        let blocks = self
            .blocks
            .iter()
            .enumerate()
            .filter(|(i, _)| !rows.contains(i))
            .map(|(_, b)| b.clone())
            .collect();
        Self::new(self.mechanism, &legs, blocks)
    }

    /// The mechanism.
    pub fn mechanism(&self) -> &'a Mechanism {
        self.mechanism
    }

    /// The legs and where their parameters sit.
    pub fn slots(&self) -> &[LegSlot] {
        &self.slots
    }

    /// The residual blocks, in row order.
    pub fn blocks(&self) -> &[ResidualBlock] {
        &self.blocks
    }

    /// Number of unknowns.
    pub fn parameter_count(&self) -> usize {
        self.slots.iter().map(|s| s.columns.len()).sum()
    }

    /// The nominal values of the unknowns (the usual starting point).
    pub fn nominal(&self) -> DVector<f64> {
        let mut x = DVector::zeros(self.parameter_count());
        for slot in &self.slots {
            let leg = &self.mechanism.legs[slot.leg];
            for (k, &c) in slot.columns.iter().enumerate() {
                x[slot.offset + k] = leg.params[c].nominal;
            }
        }
        x
    }

    /// The full parameter vector of the leg in `slot` for unknowns `x` (fixed ones at nominal).
    pub fn leg_parameters(&self, slot: &LegSlot, x: &DVector<f64>) -> Vec<f64> {
        let mut phi = self.mechanism.legs[slot.leg].nominal();
        for (k, &c) in slot.columns.iter().enumerate() {
            phi[c] = x[slot.offset + k];
        }
        phi
    }

    /// Each slot's leg prepared at the unknowns `x` (built once, reused at every pose), for
    /// the derivatives with respect to its identified parameters if `derivatives`.
    fn prepare(&self, x: &DVector<f64>, derivatives: bool) -> Vec<PreparedLeg<'a>> {
        self.slots
            .iter()
            .map(|slot| {
                let leg = &self.mechanism.legs[slot.leg];
                let columns: &[usize] = if derivatives { &slot.columns } else { &[] };
                PreparedLeg::new(leg, &self.leg_parameters(slot, x), columns)
            })
            .collect()
    }

    /// Block `index`'s platform transform: kept, or computed from its pose.
    fn platform(&self, index: usize) -> Transform<f64> {
        self.platforms
            .get(index)
            .copied()
            .unwrap_or_else(|| platform_transform_f64(&self.blocks[index].pose))
    }

    /// The evaluation state (shared with the problem's clones).
    fn lock(&self) -> MutexGuard<'_, Evaluations> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The widest slot's number of identified parameters: the stride of the kept gradients.
    fn width(&self) -> usize {
        self.slots
            .iter()
            .map(|s| s.columns.len())
            .max()
            .unwrap_or(0)
    }

    /// Calls `read` with the evaluation at the unknowns `x` (with the gradients if
    /// `derivatives`): a kept one if there is one at exactly `x`, else a new one, which is
    /// then kept. Solving a block's inverse kinematics is warm-started from its last solution.
    /// Only the newest gradients are kept: an older evaluation's are freed before new ones
    /// are computed (a large problem's are as large as its Jacobian; the solvers never ask
    /// for a Jacobian at a point before the last one they took a Jacobian at).
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    fn evaluated<R>(
        &self,
        x: &DVector<f64>,
        derivatives: bool,
        read: impl FnOnce(&Evaluation) -> R,
    ) -> Result<R, BlockError> {
        let key = key(x);
        let mut state = self.lock();
        let kept = state.recent.iter().position(|e| e.x == key);
        let mut evaluation = match kept {
            Some(i) => state.recent.remove(i),
            None => {
                // The oldest kept evaluation would go once this one is kept: it goes first
                // (a large problem's evaluations are tens of megabytes).
                state.recent.truncate(KEPT_EVALUATIONS - 1);
                if derivatives {
                    release_older_gradients(&mut state);
                }
                self.solve_rows(x, key, derivatives, &mut state)?
            }
        };
        if derivatives && evaluation.gradients.is_empty() && !self.blocks.is_empty() {
            release_older_gradients(&mut state);
            if !evaluation.solutions.is_empty() {
                let solutions = std::mem::take(&mut evaluation.solutions);
                evaluation.gradients = self.gradients(x, |i| solutions[i]);
                evaluation.solutions = solutions;
            } else if state.solved == evaluation.x {
                // The seeds are this evaluation's solutions.
                let seeds = &state.seeds;
                let leg = |i: usize| &self.mechanism.legs[self.blocks[i].leg];
                evaluation.gradients = self.gradients(x, |i| {
                    seed_solution(&seeds.values[i * seeds.stride..], leg(i))
                });
            } else {
                let key = std::mem::take(&mut evaluation.x);
                evaluation = self.solve_rows(x, key, true, &mut state)?;
            }
        }
        let value = read(&evaluation);
        state.recent.insert(0, evaluation);
        state.recent.truncate(KEPT_EVALUATIONS);
        Ok(value)
    }

    /// Solves every block's inverse kinematics at the unknowns `x` (warm-started from the
    /// state's seeds, which then hold the new solutions) and evaluates the predicted readings
    /// (and their gradients if `derivatives`). Large problems are evaluated in parallel chunks
    /// of [`ROWS_PER_TASK`] rows.
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    fn solve_rows(
        &self,
        x: &DVector<f64>,
        key: Vec<u64>,
        derivatives: bool,
        state: &mut Evaluations,
    ) -> Result<Evaluation, BlockError> {
        state.solved = Vec::new();
        let seed_stride = state.seeds.stride;
        let seeds = &mut state.seeds.values[..];
        let m = self.blocks.len();
        let width = if derivatives { self.width() } else { 0 };
        let prepared = self.prepare(x, derivatives);
        let home = &self.mechanism.home_pose;
        let keep = m <= KEPT_SOLUTION_ROWS;
        let mut predicted = vec![0.0; m];
        // Without derivatives, a placeholder column (the chunks of all three slices must pair).
        let stride = width.max(1);
        let mut gradients = vec![0.0; m * stride];
        let task = |(chunk, ((seeds, predicted), gradients)): ChunkOfRows<'_>| {
            let mut solutions = Vec::with_capacity(if keep { predicted.len() } else { 0 });
            let rows = seeds.chunks_mut(seed_stride).zip(predicted.iter_mut());
            for (k, (seed, value)) in rows.enumerate() {
                let index = chunk * ROWS_PER_TASK + k;
                let block = &self.blocks[index];
                let leg = &prepared[self.slot_of_leg[block.leg].unwrap_or_default()];
                let platform = self.platform(index);
                let warm = seed_joints(seed, leg.leg());
                let solution = leg
                    .solve_warm_on(&platform, &block.pose, home, warm.as_ref())
                    .map_err(|source| (index, source))?;
                store_seed(seed, leg.leg(), &solution);
                *value = if derivatives {
                    let gradient = &mut gradients[k * width..k * width + leg.columns()];
                    leg.reading_and_gradient_on(&platform, &solution, gradient)
                } else {
                    leg.reading_of(&solution)
                };
                if keep {
                    solutions.push(solution);
                }
            }
            Ok::<_, (usize, KinematicsError)>(solutions)
        };
        // One task a chunk of rows; rayon runs a single chunk on the calling thread.
        let results: Vec<_> = seeds
            .par_chunks_mut(ROWS_PER_TASK * seed_stride)
            .zip(predicted.par_chunks_mut(ROWS_PER_TASK))
            .zip(gradients.par_chunks_mut(ROWS_PER_TASK * stride))
            .enumerate()
            .map(task)
            .collect();
        let mut solutions = Vec::with_capacity(if keep { m } else { 0 });
        for result in results {
            match result {
                Ok(mut chunk) => solutions.append(&mut chunk),
                Err((index, source)) => return Err(self.block_error(index, source, x)),
            }
        }
        state.row_solves += m as u64;
        if width == 0 {
            gradients = Vec::new();
        }
        state.solved.clone_from(&key);
        Ok(Evaluation {
            x: key,
            solutions,
            predicted,
            gradients,
        })
    }

    /// The gradients of an evaluation at the unknowns `x` whose solutions are known
    /// (`solution(i)` of block `i`): the dual passes only, no inverse kinematics; in parallel
    /// chunks of [`ROWS_PER_TASK`] rows for a large problem.
    fn gradients(&self, x: &DVector<f64>, solution: impl Fn(usize) -> Solution + Sync) -> Vec<f64> {
        let width = self.width();
        let prepared = self.prepare(x, true);
        let mut gradients = vec![0.0; self.blocks.len() * width];
        let task = |(chunk, rows): (usize, &mut [f64])| {
            for (k, gradient) in rows.chunks_mut(width).enumerate() {
                let index = chunk * ROWS_PER_TASK + k;
                let block = &self.blocks[index];
                let leg = &prepared[self.slot_of_leg[block.leg].unwrap_or_default()];
                let gradient = &mut gradient[..leg.columns()];
                leg.reading_and_gradient_on(&self.platform(index), &solution(index), gradient);
            }
        };
        gradients
            .par_chunks_mut(ROWS_PER_TASK * width)
            .enumerate()
            .for_each(task);
        gradients
    }

    /// How many rows' inverse kinematics this problem and its clones have solved so far (a
    /// row solved at several evaluations counts each time): the cost of its evaluations, which
    /// reuse what they can. An evaluation at unknowns where one is kept solves no row; a
    /// Jacobian where the residuals were last evaluated needs the dual passes only.
    pub fn row_solves(&self) -> u64 {
        self.lock().row_solves
    }

    /// The evaluations kept for reuse (at most two) and how many of them hold their gradients
    /// (at most one: an older evaluation's are freed before another's are computed): what the
    /// problem holds in memory besides its blocks and its seeds.
    pub fn kept_evaluations(&self) -> (usize, usize) {
        let state = self.lock();
        let with_gradients = state.recent.iter().filter(|e| !e.gradients.is_empty());
        (state.recent.len(), with_gradients.count())
    }

    /// Forgets the kept evaluations but the newest, and that one's gradients (kept: its
    /// solutions and predicted readings): after a fit, once the residuals and the Jacobian at
    /// the estimate are taken, the statistics need no more (a large problem's gradients are
    /// as large as its Jacobian).
    pub fn release_gradients(&self) {
        let mut state = self.lock();
        state.recent.truncate(1);
        if let Some(newest) = state.recent.first_mut() {
            newest.gradients = Vec::new();
        }
    }

    /// Calls `row` with every block's index, its slot's leg prepared at the unknowns `x`
    /// (without derivative columns), its platform transform and its inverse-kinematics
    /// solution at `x`, in row order: the kept solutions of an evaluation at `x`, or solved
    /// again warm-started from the last ones (at `x` itself after a solve there: one Newton
    /// check per row). In parallel chunks of 512 rows for a large problem.
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    pub fn map_solved<R: Send>(
        &self,
        x: &DVector<f64>,
        row: impl Fn(usize, &PreparedLeg<'a>, &Transform<f64>, &Solution) -> R + Sync,
    ) -> Result<Vec<R>, BlockError> {
        let key = key(x);
        let mut state = self.lock();
        let kept = state
            .recent
            .iter()
            .find(|e| e.x == key && !e.solutions.is_empty());
        let solves = if kept.is_some() { 0 } else { self.blocks.len() };
        let prepared = self.prepare(x, false);
        let home = &self.mechanism.home_pose;
        let seeds = &state.seeds;
        let task = |chunk: usize| {
            let start = chunk * ROWS_PER_TASK;
            let end = (start + ROWS_PER_TASK).min(self.blocks.len());
            (start..end)
                .map(|index| {
                    let block = &self.blocks[index];
                    let leg = &prepared[self.slot_of_leg[block.leg].unwrap_or_default()];
                    let platform = self.platform(index);
                    let solution = match kept {
                        Some(evaluation) => evaluation.solutions[index],
                        None => leg
                            .solve_warm_on(
                                &platform,
                                &block.pose,
                                home,
                                seed_joints(&seeds.values[index * seeds.stride..], leg.leg())
                                    .as_ref(),
                            )
                            .map_err(|source| (index, source))?,
                    };
                    Ok(row(index, leg, &platform, &solution))
                })
                .collect::<Result<Vec<R>, (usize, KinematicsError)>>()
        };
        let chunks = self.blocks.len().div_ceil(ROWS_PER_TASK);
        let results: Vec<_> = (0..chunks).into_par_iter().map(task).collect();
        let mut values = Vec::with_capacity(self.blocks.len());
        for result in results {
            match result {
                Ok(mut chunk) => values.append(&mut chunk),
                Err((index, source)) => return Err(self.block_error(index, source, x)),
            }
        }
        state.row_solves += solves as u64;
        Ok(values)
    }

    /// Each slot's gain and whether its actuator turns, at the unknowns `x`.
    fn turn_matches(&self, x: &DVector<f64>) -> Vec<TurnMatch> {
        self.slots
            .iter()
            .map(|slot| {
                let leg = &self.mechanism.legs[slot.leg];
                TurnMatch {
                    gain: leg.geometry(&self.leg_parameters(slot, x)).gain,
                    gain_column: slot
                        .columns
                        .iter()
                        .position(|&c| leg.params[c].target == ParamTarget::Gain),
                    revolute: leg.actuated_is_revolute(),
                }
            })
            .collect()
    }

    /// `√w` of row `row` (1 when unweighted).
    pub fn row_scale(&self, row: usize) -> f64 {
        self.row_scales.as_ref().map_or(1.0, |s| s[row])
    }

    /// Residuals `predicted − measured` reading (matched modulo one turn, times `√w_i` if
    /// weighted), one per block.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn residuals(&self, x: &DVector<f64>) -> Result<DVector<f64>, BlockError> {
        let matches = self.turn_matches(x);
        self.evaluated(x, false, |evaluation| {
            DVector::from_iterator(
                self.blocks.len(),
                self.blocks.iter().enumerate().map(|(i, block)| {
                    let predicted = evaluation.predicted[i];
                    let m = matches[self.slot_of_leg[block.leg].unwrap_or_default()];
                    let n = turns(predicted, block.reading, m.gain, m.revolute);
                    self.row_scale(i)
                        * (predicted - block.reading - n * turn_in_reading_units(m.gain))
                }),
            )
        })
    }

    /// Whole turns of the actuated joint removed from each block's residual at `x` (zero for
    /// prismatic actuators): non-zero where the readings sit on another turn than the leg's
    /// home value.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn turns(&self, x: &DVector<f64>) -> Result<Vec<f64>, BlockError> {
        let matches = self.turn_matches(x);
        self.evaluated(x, false, |evaluation| {
            self.blocks
                .iter()
                .zip(&evaluation.predicted)
                .map(|(block, &predicted)| {
                    let m = matches[self.slot_of_leg[block.leg].unwrap_or_default()];
                    turns(predicted, block.reading, m.gain, m.revolute)
                })
                .collect()
        })
    }

    /// Residuals and the identification Jacobian ∂r/∂x (block-structured: a block's row is
    /// non-zero only in its own leg's columns), from one dual pass per block.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        let matches = self.turn_matches(x);
        let (m, p, width) = (self.blocks.len(), self.parameter_count(), self.width());
        self.evaluated(x, true, |evaluation| {
            let mut r = DVector::zeros(m);
            let mut jacobian = DMatrix::zeros(m, p);
            for (i, block) in self.blocks.iter().enumerate() {
                let s = self.slot_of_leg[block.leg].unwrap_or_default();
                let slot = &self.slots[s];
                let predicted = evaluation.predicted[i];
                let gradient = &evaluation.gradients[i * width..i * width + slot.columns.len()];
                let tm = matches[s];
                let n = turns(predicted, block.reading, tm.gain, tm.revolute);
                let turn = turn_in_reading_units(tm.gain);
                let scale = self.row_scale(i);
                r[i] = scale * (predicted - block.reading - n * turn);
                for (k, &g) in gradient.iter().enumerate() {
                    let mut g = g;
                    if tm.gain_column == Some(k) && n != 0.0 {
                        // d(−n·2π/gain)/d gain = n·2π/gain².
                        g += n * turn / tm.gain;
                    }
                    jacobian[(i, slot.offset + k)] = g * scale;
                }
            }
            (r, jacobian)
        })
    }

    /// The error of block `block` at the unknowns `x`, located (file line or block) and with the
    /// trial parameter values.
    pub fn block_error(
        &self,
        block: usize,
        source: KinematicsError,
        x: &DVector<f64>,
    ) -> BlockError {
        let location = match self.blocks[block].line {
            Some(line) => format!("measurement line {line}"),
            None => format!("residual block {block}"),
        };
        let parameters = self
            .slots
            .iter()
            .flat_map(|slot| {
                let leg = &self.mechanism.legs[slot.leg];
                slot.columns.iter().enumerate().map(move |(k, &c)| {
                    format!("{} = {}", leg.params[c].name, short(x[slot.offset + k]))
                })
            })
            .collect::<Vec<_>>()
            .join(", ");
        BlockError {
            block,
            source,
            location,
            parameters,
        }
    }

    /// The rows and columns of the leg in `slot` of the problem's Jacobian `c`: borrowed
    /// when they are all of it (a problem of one leg, whose slot starts at column 0), else
    /// copied.
    pub fn slot_jacobian<'c>(&self, slot: &LegSlot, c: &'c DMatrix<f64>) -> Cow<'c, DMatrix<f64>> {
        let n = slot.columns.len();
        if self.slots.len() == 1 && c.ncols() == n {
            return Cow::Borrowed(c);
        }
        let rows = self.rows_of(slot);
        Cow::Owned(DMatrix::from_fn(rows.len(), n, |i, j| {
            c[(rows[i], slot.offset + j)]
        }))
    }

    /// Row indices of the blocks of the leg in `slot`.
    pub fn rows_of(&self, slot: &LegSlot) -> Vec<usize> {
        (0..self.blocks.len())
            .filter(|&i| self.blocks[i].leg == slot.leg)
            .collect()
    }
}

/// A parameter value for messages: six decimals for ordinary magnitudes, else scientific.
fn short(value: f64) -> String {
    if value == 0.0 || (1e-3..1e6).contains(&value.abs()) {
        format!("{value:.6}")
    } else {
        format!("{value:.6e}")
    }
}

impl Operator for IdentificationProblem<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    fn apply(&self, x: &Self::Param) -> Result<Self::Output, ArgminError> {
        Ok(self.residuals(x)?)
    }
}

impl Jacobian for IdentificationProblem<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;

    fn jacobian(&self, x: &Self::Param) -> Result<Self::Jacobian, ArgminError> {
        Ok(self.residuals_and_jacobian(x)?.1)
    }
}

#[cfg(test)]
mod tests {
    use super::short;

    #[test]
    fn message_values_have_six_decimals_or_an_exponent() {
        for (value, text) in [
            (0.0, "0.000000"),
            (0.5, "0.500000"),
            (-3.25, "-3.250000"),
            (1e-3, "0.001000"),
            (999_999.0, "999999.000000"),
            (1e6, "1.000000e6"),
            (-2.5e7, "-2.500000e7"),
            (1e-4, "1.000000e-4"),
            (-9.9e-4, "-9.900000e-4"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(short(value), text, "{value}");
        }
    }
}
