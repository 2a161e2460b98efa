//! The least-squares problem of identification: residual blocks (one leg's reading at one
//! platform pose) over parameter blocks (each leg's identified parameters and, through an
//! instrument, the shared ones: its frame and target offsets). Divide and conquer (one leg),
//! traditional (several legs stacked), joint (every leg and the instrument) and two-stage
//! (the instrument alone, then the legs with it held) are groupings of the same blocks.
//! Implements argmin's `Operator` (residuals) and `Jacobian` (dual numbers), and the bordered
//! block-diagonal layout a Schur-complement solver takes
//! ([`crate::solver::bordered::BorderedLeastSquares`], `problem/solver_interface.rs`): each
//! leg's rows are one group, the shared parameters its border. The residuals and their
//! derivatives are `problem/residuals.rs`.
//!
//! A block's pose is measured, or fitted from the targets an instrument saw at the current
//! shared parameters (`problem/sighted.rs`). Rows may carry weights `w_i` (weighted least squares:
//! each residual and its Jacobian row are multiplied by `√w_i`); a revolute actuator's
//! residual is matched modulo one turn of the joint ([`super::residual::turns`]).

use std::sync::{Arc, Mutex};

use nalgebra::DVector;

use super::residual::ResidualBlock;
use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::chain::{platform_transform_f64, Transform};
use crate::kinematics::kernel::LegKernel;
use crate::measure::observations::{instrument_of, Observations};
use crate::model::instrument::Instrument;
use crate::model::Mechanism;

mod evaluation;
mod forward;
mod forward_problem;
mod forward_rows;
mod instrument_derivatives;
mod noise;
mod places;
mod pose_moves;
mod prior_rows;
mod priors;
mod reached_points;
mod residuals;
mod sighted;
mod solver_interface;
mod state;

use forward_rows::Forward;
pub use places::ResidualPlace;
pub use priors::PriorRow;
use priors::Priors;
pub use reached_points::ReachedPoint;
use sighted::{Sighted, Sighting};
use state::{Evaluations, KEPT_SOLUTION_ROWS};

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
    /// Each slot's closed-form kernel, recognised once (not at every evaluation).
    kernels: Vec<Option<LegKernel>>,
    /// Shared by the problem's clones (a solver clones its problem).
    blocks: Arc<Vec<ResidualBlock>>,
    /// Through an instrument: the shared parameters and what it saw at each block (whose
    /// measured pose is then unused, NaN).
    sighted: Option<Sighted<'a>>,
    /// Through an instrument seen by forward kinematics: the rows of every leg's reading and
    /// what the instrument saw there (`problem/forward.rs`), after the blocks in row order.
    forward: Option<Forward>,
    /// `√w_i` per residual (the blocks', the forward rows', the priors'), if weighted.
    row_scales: Option<Vec<f64>>,
    /// The priors' residual rows after the data's, and each unknown's prior σ
    /// (`problem/prior_rows.rs`).
    priors: Arc<Priors>,
    /// Each block's platform transform (its pose's trigonometry done once), for problems of
    /// measured poses of at most [`KEPT_SOLUTION_ROWS`] blocks (96 bytes a row); empty for
    /// larger ones, whose rows compute theirs at each evaluation, and through an instrument.
    platforms: Arc<[Transform<f64>]>,
    /// Each block's last inverse-kinematics solution (the warm start of the next evaluation)
    /// and the values of the latest evaluations. Shared by the problem's clones (a solver
    /// clones its problem, and refines the estimate on the original): a problem and its clones
    /// are evaluated one after the other, never at once. A problem derived with other rows,
    /// columns or held values starts its own.
    state: Arc<Mutex<Evaluations<'a>>>,
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

impl<'a> IdentificationProblem<'a> {
    /// A problem identifying the legs `legs` from `blocks` at their measured poses (blocks of
    /// other legs are ignored). Its rows are the data's alone (priors are added by
    /// [`Self::with_priors`]).
    pub fn new(mechanism: &'a Mechanism, legs: &[usize], blocks: Vec<ResidualBlock>) -> Self {
        Self::assemble(mechanism, legs, blocks, None)
    }

    /// The problem of every identified leg and the instrument's identified parameters, from
    /// `observations` (a leg's labelled rows, or the shared rows, as divide and conquer picks
    /// them), each leg's rows one group in model order. Unknowns:
    /// `x = [own₀ | own₁ | … | shared]`, each leg's identified parameters in model order, then
    /// the identified shared parameters in the instrument's order. Its rows are the data's
    /// alone (priors are added by [`Self::with_priors`]).
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
        let kernel = |slot: &LegSlot| LegKernel::recognise(&mechanism.legs[slot.leg]);
        let kernels = slots.iter().map(kernel).collect();
        let measured = sighted.is_none() && blocks.len() <= KEPT_SOLUTION_ROWS;
        Self {
            priors: Default::default(),
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
            kernels,
            sighted,
            forward: None,
            row_scales: None,
            state: Arc::new(Mutex::new(state)),
        }
    }

    /// The same problem with row weights `weights` (one per residual, in row order: the
    /// blocks', then a forward problem's rows'; finite and non-negative): residual `i` and its
    /// Jacobian row are multiplied by `√weights[i]`. A missing weight counts as 1.
    pub fn with_weights(mut self, weights: &[f64]) -> Self {
        self.row_scales = Some(
            (0..self.blocks.len().max(weights.len()))
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
        problem.priors = self.priors.clone();
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
        // No leg unknown is left: no leg prior either.
        problem.priors = Default::default();
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
}
