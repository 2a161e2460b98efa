//! The least-squares problem of identification: residual blocks (one leg's reading at one
//! platform pose) over parameter blocks (each leg's identified parameters and, through an
//! instrument, the shared ones: its frame and target offsets). Divide and conquer (one leg),
//! traditional (several legs stacked), joint (every leg and the instrument) and two-stage
//! (the instrument alone, then the legs with it held) are groupings of the same blocks.
//! Implements argmin's `Operator` (residuals) and `Jacobian` (dual numbers), and the bordered
//! block-diagonal layout a Schur-complement solver takes ([`BorderedLeastSquares`]): each
//! leg's rows are one group, the shared parameters its border.
//!
//! A block's pose is measured, or fitted from the targets an instrument saw at the current
//! shared parameters (`problem/sighted.rs`). Rows may carry weights `w_i` (weighted least squares:
//! each residual and its Jacobian row are multiplied by `√w_i`); a revolute actuator's
//! residual is matched modulo one turn of the joint ([`super::residual::turns`]).

use std::borrow::Cow;
use std::sync::{Arc, Mutex};

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use nalgebra::{DMatrix, DVector};

use super::residual::{turn_in_reading_units, turns, ResidualBlock};
use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::chain::{platform_transform_f64, Transform};
use crate::measure::observations::{instrument_of, Observations};
use crate::measure::targets::platform_pose;
use crate::model::instrument::Instrument;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;
use crate::solver::bordered::{BorderedBlock, BorderedLayout, BorderedLeastSquares};

mod evaluation;
mod forward;
mod forward_problem;
mod forward_rows;
mod noise;
mod reached_points;
mod sighted;
mod state;

use forward_rows::Forward;
pub use reached_points::ReachedPoint;
use sighted::{Sighted, Sighting};
use state::{Evaluation, Evaluations, KEPT_SOLUTION_ROWS};

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
/// the measurement line from [`BlockError::block`] and [`BlockError::source`] (or
/// [`BlockError::location`]); the message of the error itself is for a failure *during* a
/// solve (a solver passes it on): there the trial parameters are at fault, not the data, and
/// the message says so with their values.
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
    /// `measurement line N`, or `residual block N` for a pose without a file line; through an
    /// instrument, the leg and `the pose fitted from the targets (measurement line N)`.
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
    /// Through an instrument: the shared parameters and what it saw at each block (whose
    /// measured pose is then unused, NaN).
    sighted: Option<Sighted<'a>>,
    /// Through an instrument seen by forward kinematics: the rows of every leg's reading and
    /// what the instrument saw there (`problem/forward.rs`), after the blocks in row order.
    forward: Option<Forward>,
    /// `√w_i` per block, if weighted.
    row_scales: Option<Vec<f64>>,
    /// Each block's platform transform (its pose's trigonometry done once), for problems of
    /// measured poses of at most [`KEPT_SOLUTION_ROWS`] blocks (96 bytes a row); empty for
    /// larger ones, whose rows compute theirs at each evaluation, and through an instrument.
    platforms: Arc<[Transform<f64>]>,
    /// Each block's last inverse-kinematics solution (the warm start of the next evaluation)
    /// and the values of the latest evaluations. Shared by the problem's clones (a solver
    /// clones its problem, and refines the estimate on the original): a problem and its clones
    /// are evaluated one after the other, never at once. A problem derived with other rows,
    /// columns or held values starts its own.
    state: Arc<Mutex<Evaluations>>,
}

/// A block's platform pose at one evaluation and its transform.
#[derive(Debug, Clone, Copy)]
pub struct Placed {
    /// `[x, y, z, roll, pitch, yaw]`: measured, or fitted from the block's targets.
    pub pose: [f64; 6],
    /// Its platform transform.
    pub platform: Transform<f64>,
}

impl Placed {
    /// The platform at `pose`.
    fn at(pose: [f64; 6]) -> Self {
        Self {
            platform: platform_transform_f64(&pose),
            pose,
        }
    }
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
    /// A problem identifying the legs `legs` from `blocks` at their measured poses (blocks of
    /// other legs are ignored).
    pub fn new(mechanism: &'a Mechanism, legs: &[usize], blocks: Vec<ResidualBlock>) -> Self {
        Self::assemble(mechanism, legs, blocks, None)
    }

    /// The problem of every identified leg and the instrument's identified parameters, from
    /// `observations` (a leg's labelled rows, or the shared rows, as divide and conquer picks
    /// them), each leg's rows one group in model order. Unknowns:
    /// `x = [own₀ | own₁ | … | shared]`, each leg's identified parameters in model order, then
    /// the identified shared parameters in the instrument's order.
    ///
    /// # Errors
    /// [`Error::Model`] if the model has no instrument; [`Error::Invalid`] if a leg has no row.
    pub fn through_instrument(
        mechanism: &'a Mechanism,
        observations: &Observations,
    ) -> Result<Self> {
        let instrument = instrument_of(mechanism)?;
        let legs = mechanism.identified_legs();
        if instrument.forward {
            return Self::forward(mechanism, observations, &legs);
        }
        let (mut blocks, mut rows) = (Vec::new(), Vec::new());
        for &leg in &legs {
            let leg_rows = observations.indexed_leg_rows(leg);
            if leg_rows.is_empty() {
                return Err(Error::Invalid(format!(
                    "no measurement row carries a reading of leg `{}`",
                    mechanism.legs[leg].name
                )));
            }
            for (source, row, reading) in leg_rows {
                blocks.push(ResidualBlock {
                    leg,
                    pose: [f64::NAN; 6],
                    reading,
                    line: row.line,
                });
                let observed = row.observed.clone();
                rows.push(Sighting { source, observed });
            }
        }
        let sighted = Sighted {
            instrument,
            shared: instrument.identified(),
            held: instrument.nominal(),
            rows: Arc::new(rows),
        };
        Ok(Self::assemble(mechanism, &legs, blocks, Some(sighted)))
    }

    /// The problem of the legs `legs` (their identified parameters unknown), the blocks of
    /// those legs and, through an instrument, what it saw at each block.
    fn assemble(
        mechanism: &'a Mechanism,
        legs: &[usize],
        blocks: Vec<ResidualBlock>,
        sighted: Option<Sighted<'a>>,
    ) -> Self {
        let slots = legs
            .iter()
            .map(|&leg| (leg, mechanism.legs[leg].identified()))
            .collect();
        Self::with_slots(mechanism, slots, blocks, sighted)
    }

    /// The problem of the legs and identified columns `slots`, in that order. Blocks of other
    /// legs are dropped; through an instrument there are none (`sighted` holds one row per
    /// block).
    fn with_slots(
        mechanism: &'a Mechanism,
        slots: Vec<(usize, Vec<usize>)>,
        blocks: Vec<ResidualBlock>,
        sighted: Option<Sighted<'a>>,
    ) -> Self {
        let mut slot_of_leg = vec![None; mechanism.legs.len()];
        let mut offset = 0;
        let slots: Vec<LegSlot> = slots
            .into_iter()
            .enumerate()
            .map(|(s, (leg, columns))| {
                slot_of_leg[leg] = Some(s);
                offset += columns.len();
                LegSlot {
                    leg,
                    offset: offset - columns.len(),
                    columns,
                }
            })
            .collect();
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
        let measured = sighted.is_none() && blocks.len() <= KEPT_SOLUTION_ROWS;
        Self {
            platforms: if measured {
                let platform = |b: &ResidualBlock| platform_transform_f64(&b.pose);
                blocks.iter().map(platform).collect()
            } else {
                Arc::from(Vec::new())
            },
            blocks,
            mechanism,
            slots,
            slot_of_leg,
            sighted,
            forward: None,
            row_scales: None,
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

    /// The same unknowns on the blocks `keep` picks (by row index), without weights and with
    /// its own evaluation state.
    fn with_blocks(&self, keep: impl Fn(usize) -> bool) -> Self {
        let blocks = (0..self.blocks.len())
            .filter(|&i| keep(i))
            .map(|i| self.blocks[i].clone())
            .collect();
        let sighted = match self.sighting() {
            Some(s) => Some(Sighted {
                rows: Arc::new(
                    (0..self.blocks.len())
                        .filter(|&i| keep(i))
                        .map(|i| s.rows[i].clone())
                        .collect(),
                ),
                ..s.clone()
            }),
            None => self.sighted.clone(),
        };
        let slots = self.slots.iter().map(|s| (s.leg, s.columns.clone()));
        let mut problem = Self::with_slots(self.mechanism, slots.collect(), blocks, sighted);
        problem.forward = self.forward.as_ref().map(|f| f.renewed(&keep));
        problem
    }

    /// The same legs without the blocks at rows `rows` (and without weights).
    pub fn without_rows(&self, rows: &[usize]) -> Self {
        self.with_blocks(|i| !rows.contains(&i))
    }

    /// The same problem on the first `count` rows of every leg only ([`Self::first_rows`]).
    pub fn with_rows(&self, count: usize) -> Self {
        let first = self.first_rows(count);
        self.with_blocks(|i| first.binary_search(&i).is_ok())
    }

    /// The indices (ascending) of the first `count` rows of every leg: the rows of
    /// [`Self::with_rows`], in its order.
    pub fn first_rows(&self, count: usize) -> Vec<usize> {
        let mut seen = vec![0; self.mechanism.legs.len()];
        (0..self.blocks.len())
            .filter(|&i| {
                let leg = self.blocks[i].leg;
                seen[leg] += 1;
                seen[leg] <= count
            })
            .collect()
    }

    /// The same problem with every shared parameter held at `values` (all of them, in the
    /// instrument's order): the legs separate again (the two-stage alternative's second stage,
    /// or a frame taken as known). Without an instrument, the same problem.
    pub fn with_shared_fixed(&self, values: &[f64]) -> Self {
        let mut problem = self.with_blocks(|_| true);
        if let Some(sighted) = problem.sighted.as_mut() {
            sighted.shared = Vec::new();
            sighted.held = values.to_vec();
        }
        problem
    }

    /// The same problem with every leg parameter held at its nominal value: only the shared
    /// parameters are unknown (the two-stage alternative's registration of the frame).
    pub fn with_legs_fixed(&self) -> Self {
        let slots = self.slots.iter().map(|s| (s.leg, Vec::new())).collect();
        let blocks = self.blocks.to_vec();
        let mut problem = Self::with_slots(self.mechanism, slots, blocks, self.sighted.clone());
        problem.forward = self.forward.as_ref().map(|f| f.renewed(|_| true));
        problem
    }

    /// The mechanism.
    pub fn mechanism(&self) -> &'a Mechanism {
        self.mechanism
    }

    /// The instrument the problem sees the platform through, if any.
    pub fn instrument(&self) -> Option<&'a Instrument> {
        self.sighted.as_ref().map(|s| s.instrument)
    }

    /// What the instrument saw at each block, when the blocks' poses are fitted from its
    /// targets; `None` when they are measured (no instrument, or a forward problem's blocks of
    /// measured poses).
    fn sighting(&self) -> Option<&Sighted<'a>> {
        self.sighted.as_ref().filter(|_| self.forward.is_none())
    }

    /// The legs and where their parameters sit.
    pub fn slots(&self) -> &[LegSlot] {
        &self.slots
    }

    /// Indices of the legs, one per slot.
    pub fn legs(&self) -> Vec<usize> {
        self.slots.iter().map(|s| s.leg).collect()
    }

    /// The residual blocks, in row order.
    pub fn blocks(&self) -> &[ResidualBlock] {
        &self.blocks
    }

    /// Indices (into the instrument's parameters) of the identified shared parameters (none
    /// without an instrument).
    pub fn shared_columns(&self) -> &[usize] {
        self.sighted.as_ref().map_or(&[], |s| &s.shared)
    }

    /// Number of unknowns.
    pub fn parameter_count(&self) -> usize {
        self.own_columns() + self.shared_columns().len()
    }

    /// Number of the legs' unknowns (the first ones).
    fn own_columns(&self) -> usize {
        self.slots.iter().map(|s| s.columns.len()).sum()
    }

    /// The widest slot's number of identified parameters.
    fn own_width(&self) -> usize {
        let widths = self.slots.iter().map(|s| s.columns.len());
        widths.max().unwrap_or(0)
    }

    /// Values a block's kept gradient takes: the widest slot's, then the shared parameters'.
    fn gradient_stride(&self) -> usize {
        self.own_width() + self.shared_columns().len()
    }

    /// Names of the unknowns, in the order of `x`.
    pub fn names(&self) -> Vec<String> {
        let legs = self.slots.iter().flat_map(|slot| {
            let leg = &self.mechanism.legs[slot.leg];
            slot.columns.iter().map(|&c| leg.params[c].name.clone())
        });
        let shared = self.sighted.iter().flat_map(|s| {
            let name = |&k: &usize| s.instrument.parameters[k].name.clone();
            s.shared.iter().map(name)
        });
        legs.chain(shared).collect()
    }

    /// The starting unknowns: the legs' nominal parameters, the shared ones at their held
    /// values (nominal unless [`Self::with_shared_fixed`] set them).
    pub fn start(&self) -> DVector<f64> {
        let mut x = DVector::zeros(self.parameter_count());
        for slot in &self.slots {
            let leg = &self.mechanism.legs[slot.leg];
            for (k, &c) in slot.columns.iter().enumerate() {
                x[slot.offset + k] = leg.params[c].nominal;
            }
        }
        if let Some(sighted) = &self.sighted {
            let first = self.own_columns();
            for (i, &k) in sighted.shared.iter().enumerate() {
                x[first + i] = sighted.held[k];
            }
        }
        x
    }

    /// Every shared parameter's value at `x` (the ones not identified at their held values;
    /// none without an instrument).
    pub fn shared_values(&self, x: &DVector<f64>) -> Vec<f64> {
        self.sighted
            .as_ref()
            .map_or_else(Vec::new, |s| s.values(x.as_slice()))
    }

    /// The full parameter vector of the leg in `slot` for unknowns `x` (fixed ones at nominal).
    pub fn leg_parameters(&self, slot: &LegSlot, x: &DVector<f64>) -> Vec<f64> {
        let mut phi = self.mechanism.legs[slot.leg].nominal();
        for (k, &c) in slot.columns.iter().enumerate() {
            phi[c] = x[slot.offset + k];
        }
        phi
    }

    /// Block `index`'s platform: its measured pose (its transform kept), or the pose fitted
    /// from its targets at the shared values `shared`.
    fn placed(&self, index: usize, shared: &[f64]) -> Placed {
        match self.sighting() {
            Some(sighted) => {
                let observed = &sighted.rows[index].observed;
                let home = &self.mechanism.home_pose;
                Placed::at(platform_pose::<f64>(
                    sighted.instrument,
                    shared,
                    observed,
                    home,
                ))
            }
            None => {
                let pose = self.blocks[index].pose;
                match self.platforms.get(index) {
                    Some(&platform) => Placed { pose, platform },
                    None => Placed::at(pose),
                }
            }
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
        let blocks = self.block_residuals(x)?;
        if self.forward.is_none() {
            return Ok(blocks);
        }
        // The blocks' rows, then the forward rows'.
        let forward = self.evaluate_forward(x, false)?.residuals;
        if blocks.is_empty() {
            return Ok(DVector::from_vec(forward));
        }
        let count = blocks.len() + forward.len();
        Ok(DVector::from_iterator(
            count,
            blocks.iter().copied().chain(forward),
        ))
    }

    /// The blocks' residuals (of [`Self::residuals`]).
    fn block_residuals(&self, x: &DVector<f64>) -> Result<DVector<f64>, BlockError> {
        if self.blocks.is_empty() {
            return Ok(DVector::zeros(0));
        }
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

    /// Row `i`'s residual at `evaluation` (turn-matched, times `√w_i`), each of its
    /// derivatives passed to `put`.
    fn row_derivatives(
        &self,
        (i, evaluation, matches): (usize, &Evaluation, &[TurnMatch]),
        mut put: impl FnMut(Column, f64),
    ) -> f64 {
        let block = &self.blocks[i];
        let s = self.slot_of_leg[block.leg].unwrap_or_default();
        let width = self.gradient_stride();
        let gradient = &evaluation.gradients[i * width..(i + 1) * width];
        let predicted = evaluation.predicted[i];
        let tm = matches[s];
        let n = turns(predicted, block.reading, tm.gain, tm.revolute);
        let turn = turn_in_reading_units(tm.gain);
        let scale = self.row_scale(i);
        for (k, &g) in gradient[..self.slots[s].columns.len()].iter().enumerate() {
            let mut g = g;
            if tm.gain_column == Some(k) && n != 0.0 {
                // d(−n·2π/gain)/d gain = n·2π/gain².
                g += n * turn / tm.gain;
            }
            put(Column::Own(k), g * scale);
        }
        for (j, &g) in gradient[self.own_width()..].iter().enumerate() {
            put(Column::Shared(j), g * scale);
        }
        scale * (predicted - block.reading - n * turn)
    }

    /// Residuals and the identification Jacobian ∂r/∂x (block-structured: a block's row is
    /// non-zero only in its own leg's columns and the shared ones), from one dual pass per
    /// block.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        let (r, jacobian) = self.block_residuals_and_jacobian(x)?;
        if self.forward.is_none() {
            return Ok((r, jacobian));
        }
        // The blocks' rows, then the forward rows'.
        let forward = self.evaluate_forward(x, true)?;
        let below = forward
            .jacobian
            .unwrap_or_else(|| DMatrix::zeros(0, self.parameter_count()));
        if r.is_empty() {
            return Ok((DVector::from_vec(forward.residuals), below));
        }
        let (m, count) = (r.len(), forward.residuals.len());
        let mut stacked = DMatrix::zeros(m + count, self.parameter_count());
        stacked.rows_mut(0, m).copy_from(&jacobian);
        stacked.rows_mut(m, count).copy_from(&below);
        let all = r.iter().copied().chain(forward.residuals);
        Ok((DVector::from_iterator(m + count, all), stacked))
    }

    /// The blocks' residuals and Jacobian (of [`Self::residuals_and_jacobian`]).
    fn block_residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        if self.blocks.is_empty() {
            return Ok((DVector::zeros(0), DMatrix::zeros(0, self.parameter_count())));
        }
        let matches = self.turn_matches(x);
        let (m, p, first) = (
            self.blocks.len(),
            self.parameter_count(),
            self.own_columns(),
        );
        self.evaluated(x, true, |evaluation| {
            let mut r = DVector::zeros(m);
            let mut jacobian = DMatrix::zeros(m, p);
            for (i, block) in self.blocks.iter().enumerate() {
                let offset = self.slots[self.slot_of_leg[block.leg].unwrap_or_default()].offset;
                r[i] = self.row_derivatives((i, evaluation, &matches), |column, g| {
                    let j = match column {
                        Column::Own(k) => offset + k,
                        Column::Shared(k) => first + k,
                    };
                    jacobian[(i, j)] = g;
                });
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
        let mut location = match self.blocks[block].line {
            Some(line) => format!("measurement line {line}"),
            None => format!("residual block {block}"),
        };
        if self.sighting().is_some() {
            let leg = &self.mechanism.legs[self.blocks[block].leg].name;
            location = format!("leg `{leg}` at the pose fitted from the targets ({location})");
        }
        BlockError {
            block,
            source,
            location,
            parameters: self.trial_parameters(x),
        }
    }

    /// The unknowns `x` by name, `name = value, …`, for a message.
    fn trial_parameters(&self, x: &DVector<f64>) -> String {
        self.names()
            .iter()
            .zip(x.iter())
            .map(|(name, &value)| format!("{name} = {}", short(value)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The rows and columns of the leg in `slot` of the problem's Jacobian `c`: borrowed
    /// when they are all of it (a problem of one leg, whose slot starts at column 0), else
    /// copied.
    pub fn slot_jacobian<'c>(&self, slot: &LegSlot, c: &'c DMatrix<f64>) -> Cow<'c, DMatrix<f64>> {
        let n = slot.columns.len();
        if self.slots.len() == 1 && c.ncols() == n {
            return Cow::Borrowed(c);
        }
        // Forward rows are every leg's: all the rows.
        let rows: Vec<usize> = match self.forward {
            Some(_) => (0..c.nrows()).collect(),
            None => self.rows_of(slot),
        };
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

/// A column of a row's derivatives: the `k`-th identified parameter of its leg, or the
/// `k`-th identified shared parameter.
#[derive(Debug, Clone, Copy)]
enum Column {
    Own(usize),
    Shared(usize),
}

impl BorderedLeastSquares for IdentificationProblem<'_> {
    fn layout(&self) -> BorderedLayout {
        if self.forward.is_some() {
            // Every forward row couples every leg: one group of all the legs' columns.
            return BorderedLayout {
                own: vec![self.own_columns()],
                shared: self.shared_columns().len(),
            };
        }
        BorderedLayout {
            own: self.slots.iter().map(|s| s.columns.len()).collect(),
            shared: self.shared_columns().len(),
        }
    }

    /// Each slot's rows: their residuals, their derivatives with respect to the slot's own
    /// columns and to the shared ones.
    fn bordered(&self, x: &DVector<f64>) -> std::result::Result<Vec<BorderedBlock>, ArgminError> {
        if self.forward.is_some() {
            let (r, jacobian) = self.residuals_and_jacobian(x)?;
            let own = self.own_columns();
            return Ok(vec![BorderedBlock {
                own: jacobian.columns(0, own).into_owned(),
                shared: jacobian.columns(own, jacobian.ncols() - own).into_owned(),
                residuals: r,
            }]);
        }
        let matches = self.turn_matches(x);
        let s = self.shared_columns().len();
        let blocks = self.evaluated(x, true, |evaluation| {
            let block = |slot: &LegSlot| {
                let rows = self.rows_of(slot);
                let mut block = BorderedBlock {
                    residuals: DVector::zeros(rows.len()),
                    own: DMatrix::zeros(rows.len(), slot.columns.len()),
                    shared: DMatrix::zeros(rows.len(), s),
                };
                for (row, &i) in rows.iter().enumerate() {
                    let (own, shared) = (&mut block.own, &mut block.shared);
                    block.residuals[row] =
                        self.row_derivatives((i, evaluation, &matches), |column, g| match column {
                            Column::Own(k) => own[(row, k)] = g,
                            Column::Shared(k) => shared[(row, k)] = g,
                        });
                }
                block
            };
            self.slots.iter().map(block).collect()
        })?;
        Ok(blocks)
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
