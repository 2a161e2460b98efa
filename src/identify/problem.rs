//! The least-squares problem of one leg (divide and conquer) or of several legs stacked
//! (traditional): the same residual blocks, grouped differently. Implements argmin's
//! `Operator` (residuals) and `Jacobian` (dual numbers).
//!
//! Rows may carry weights `w_i` (weighted least squares: each residual and its Jacobian row are
//! multiplied by `√w_i`); a revolute actuator's residual is matched modulo one turn of the
//! joint ([`super::residual::turns`]).

use std::sync::{Arc, Mutex, MutexGuard};

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::jacobian::PreparedLeg;
use super::residual::{turn_in_reading_units, turns, ResidualBlock};
use crate::error::KinematicsError;
use crate::kinematics::inverse::{Joints, Solution};
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
    blocks: Arc<[ResidualBlock]>,
    /// `√w_i` per block, if weighted.
    row_scales: Option<Vec<f64>>,
    /// Each block's last inverse-kinematics solution, the warm start of the next evaluation.
    warm: WarmStarts,
}

/// Rows per task: a problem with more rows is evaluated in parallel (rayon), in chunks of this
/// many rows. The chunks do not depend on the number of threads, and every row's warm start
/// only on that row's own history, so neither do the results.
const ROWS_PER_TASK: usize = 512;

/// Each block's joints at its last solved evaluation (`None` before the first): the warm start
/// of its next inverse-kinematics solve. A value of its problem: a clone copies it.
#[derive(Debug, Default)]
struct WarmStarts(Mutex<Vec<Option<Joints>>>);

impl WarmStarts {
    /// The seeds, one per block of a problem of `blocks` blocks.
    fn lock(&self, blocks: usize) -> MutexGuard<'_, Vec<Option<Joints>>> {
        let mut seeds = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if seeds.len() != blocks {
            *seeds = vec![None; blocks];
        }
        seeds
    }
}

impl Clone for WarmStarts {
    fn clone(&self) -> Self {
        let seeds = self.0.lock().unwrap_or_else(|e| e.into_inner());
        Self(Mutex::new(seeds.clone()))
    }
}

/// What one row's evaluation sees: its index, its slot, the slot's prepared leg, its block and
/// its inverse-kinematics solution.
struct Row<'r, 'a> {
    index: usize,
    slot: usize,
    leg: &'r PreparedLeg<'a>,
    block: &'r ResidualBlock,
    solution: &'r Solution,
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
        let blocks: Arc<[ResidualBlock]> = blocks
            .into_iter()
            .filter(|b| slot_of_leg[b.leg].is_some())
            .collect();
        Self {
            mechanism,
            slots,
            slot_of_leg,
            blocks,
            row_scales: None,
            warm: WarmStarts::default(),
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

    /// The row weights, if the problem is weighted.
    pub fn weights(&self) -> Option<Vec<f64>> {
        self.row_scales
            .as_ref()
            .map(|s| s.iter().map(|v| v * v).collect())
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

    /// Solves every block's inverse kinematics at the unknowns `x` (warm-started from its last
    /// solution) and calls `evaluate` with the row and its `width` values of `out` (row-major,
    /// `width ≥ 1`). Large problems are evaluated in parallel chunks of [`ROWS_PER_TASK`] rows.
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    fn for_each_row<F>(
        &self,
        x: &DVector<f64>,
        derivatives: bool,
        width: usize,
        out: &mut [f64],
        evaluate: F,
    ) -> Result<(), BlockError>
    where
        F: Fn(&Row<'_, 'a>, &mut [f64]) + Sync,
    {
        let prepared = self.prepare(x, derivatives);
        let home = &self.mechanism.home_pose;
        let mut seeds = self.warm.lock(self.blocks.len());
        let task = |(chunk, (seeds, out)): (usize, (&mut [Option<Joints>], &mut [f64]))| {
            let rows = seeds.iter_mut().zip(out.chunks_mut(width));
            for (k, (seed, values)) in rows.enumerate() {
                let index = chunk * ROWS_PER_TASK + k;
                let block = &self.blocks[index];
                let slot = self.slot_of_leg[block.leg].unwrap_or_default();
                let leg = &prepared[slot];
                let solution = leg
                    .solve_warm(&block.pose, home, seed.as_ref())
                    .map_err(|source| (index, source))?;
                *seed = Some(solution.q);
                let row = Row {
                    index,
                    slot,
                    leg,
                    block,
                    solution: &solution,
                };
                evaluate(&row, values);
            }
            Ok::<(), (usize, KinematicsError)>(())
        };
        let results: Vec<_> = if self.blocks.len() > ROWS_PER_TASK {
            seeds
                .par_chunks_mut(ROWS_PER_TASK)
                .zip(out.par_chunks_mut(ROWS_PER_TASK * width))
                .enumerate()
                .map(task)
                .collect()
        } else {
            seeds
                .chunks_mut(ROWS_PER_TASK)
                .zip(out.chunks_mut(ROWS_PER_TASK * width))
                .enumerate()
                .map(task)
                .collect()
        };
        match results.into_iter().find_map(Result::err) {
            Some((index, source)) => Err(self.block_error(index, source, x)),
            None => Ok(()),
        }
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
        let mut r = DVector::zeros(self.blocks.len());
        self.for_each_row(x, false, 1, r.as_mut_slice(), |row, out| {
            let predicted = row.leg.reading_of(row.solution);
            let m = matches[row.slot];
            let n = turns(predicted, row.block.reading, m.gain, m.revolute);
            out[0] = self.row_scale(row.index)
                * (predicted - row.block.reading - n * turn_in_reading_units(m.gain));
        })?;
        Ok(r)
    }

    /// Whole turns of the actuated joint removed from each block's residual at `x` (zero for
    /// prismatic actuators): non-zero where the readings sit on another turn than the leg's
    /// home value.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn turns(&self, x: &DVector<f64>) -> Result<Vec<f64>, BlockError> {
        let matches = self.turn_matches(x);
        let mut n = vec![0.0; self.blocks.len()];
        self.for_each_row(x, false, 1, &mut n, |row, out| {
            let predicted = row.leg.reading_of(row.solution);
            let m = matches[row.slot];
            out[0] = turns(predicted, row.block.reading, m.gain, m.revolute);
        })?;
        Ok(n)
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
        let p = self.parameter_count();
        // Column i: row i's residual, then its Jacobian row.
        let mut rows = DMatrix::zeros(1 + p, self.blocks.len());
        self.for_each_row(x, true, 1 + p, rows.as_mut_slice(), |row, out| {
            let slot = &self.slots[row.slot];
            let (residual, jacobian) = out.split_at_mut(1);
            let gradient = &mut jacobian[slot.offset..slot.offset + slot.columns.len()];
            let predicted =
                row.leg
                    .reading_and_gradient_of(&row.block.pose, row.solution, gradient);
            let m = matches[row.slot];
            let n = turns(predicted, row.block.reading, m.gain, m.revolute);
            let turn = turn_in_reading_units(m.gain);
            if let (Some(k), true) = (m.gain_column, n != 0.0) {
                // d(−n·2π/gain)/d gain = n·2π/gain².
                gradient[k] += n * turn / m.gain;
            }
            let scale = self.row_scale(row.index);
            residual[0] = scale * (predicted - row.block.reading - n * turn);
            for g in gradient.iter_mut() {
                *g *= scale;
            }
        })?;
        let r = rows.row(0).transpose();
        let jacobian = rows.rows(1, p).transpose();
        Ok((r, jacobian))
    }

    /// The error for block `block` failing at the unknowns `x`.
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
