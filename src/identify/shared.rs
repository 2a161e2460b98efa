//! The identification with the instrument's shared parameters: every leg's own parameters
//! plus the frame and target offsets, which all legs share (a bordered block-diagonal least
//! squares problem, [`BorderedLeastSquares`]).
//!
//! At row `j` of leg `i`, the platform pose is fitted from the row's target coordinates at the
//! current shared parameters `s` ([`platform_pose`]), and the residual is the leg's reading
//! residual at that pose (matched modulo one turn as in [`super::problem`]). Its derivatives:
//! with respect to the leg's own parameters, the dual pass of
//! [`PreparedLeg`](super::jacobian::PreparedLeg); with respect to `s`, the chain rule through
//! the reading's Newton step and the pose fit (docs/method.md §13). The latest evaluations are
//! kept, so that the blocks evaluated where the residuals were cost the derivative passes
//! only. Each leg's rows are one group: divide and conquer's per-leg structure is kept, and a
//! Schur-complement Levenberg–Marquardt factors each leg's block on its own
//! ([`crate::solver::solve_bordered`]).
//!
//! [`platform_pose`]: crate::measure::targets::platform_pose

use std::sync::{Arc, Mutex};

use argmin::core::{Error as ArgminError, Operator};
use nalgebra::{DMatrix, DVector};

use super::residual::{turn_in_reading_units, turns};
use crate::error::{Error, Result};
use crate::measure::observations::{instrument_of, Observations};
use crate::model::instrument::Instrument;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;
use crate::solver::bordered::{BorderedBlock, BorderedLayout, BorderedLeastSquares};

mod evaluation;
mod noise;
mod state;

use state::Evaluations;

/// One row of one leg: the targets' coordinates and the leg's reading.
#[derive(Debug, Clone)]
struct Row {
    /// The row's index in the observations: the rows of several legs with the same index are
    /// one measurement, whose target noise reaches every leg's residual.
    source: usize,
    observed: Vec<f64>,
    reading: f64,
    line: Option<usize>,
}

/// One group: a leg, its identified columns and its rows.
#[derive(Debug, Clone)]
struct Group {
    leg: usize,
    columns: Vec<usize>,
    rows: Vec<Row>,
}

/// The least-squares problem of the legs and the instrument's shared parameters. Unknowns:
/// `x = [own₀ | own₁ | … | shared]`, each leg's identified parameters in model order, then the
/// identified shared parameters in the instrument's order.
#[derive(Debug, Clone)]
pub struct SharedProblem<'a> {
    mechanism: &'a Mechanism,
    instrument: &'a Instrument,
    groups: Vec<Group>,
    shared: Vec<usize>,
    /// Every shared value, the ones not identified held there (nominal unless set).
    fixed: Vec<f64>,
    /// Each row's last inverse-kinematics solution (the warm start of its next evaluation)
    /// and the latest evaluations, shared by the problem's clones (a solver clones its
    /// problem and refines on the original); a problem derived with other rows, columns or
    /// held values starts its own.
    state: Arc<Mutex<Evaluations>>,
}

impl<'a> SharedProblem<'a> {
    /// The problem over the identified legs with rows in `observations` (as divide and conquer
    /// picks them: a leg's labelled rows, or the shared rows) and the identified shared
    /// parameters.
    ///
    /// # Errors
    /// [`Error::Model`] if the model has no instrument; [`Error::Invalid`] if a leg has no row.
    pub fn new(mechanism: &'a Mechanism, observations: &Observations) -> Result<Self> {
        let instrument = instrument_of(mechanism)?;
        let mut groups = Vec::new();
        for leg in mechanism.identified_legs() {
            let rows: Vec<Row> = observations
                .indexed_leg_rows(leg)
                .into_iter()
                .map(|(source, row, reading)| Row {
                    source,
                    observed: row.observed.clone(),
                    reading,
                    line: row.line,
                })
                .collect();
            if rows.is_empty() {
                return Err(Error::Invalid(format!(
                    "no measurement row carries a reading of leg `{}`",
                    mechanism.legs[leg].name
                )));
            }
            groups.push(Group {
                leg,
                columns: mechanism.legs[leg].identified(),
                rows,
            });
        }
        Ok(Self {
            mechanism,
            instrument,
            groups,
            shared: instrument.identified(),
            fixed: instrument.nominal(),
            state: Arc::default(),
        })
    }

    /// The same problem with every shared parameter held at `values` (all of them, in the
    /// instrument's order): the legs separate again (the two-stage alternative's second stage,
    /// or a frame taken as known).
    pub fn with_shared_fixed(&self, values: &[f64]) -> Self {
        Self {
            shared: Vec::new(),
            fixed: values.to_vec(),
            state: Arc::default(),
            ..self.clone()
        }
    }

    /// The same problem with every leg parameter held at its nominal value: only the shared
    /// parameters are unknown (the two-stage alternative's registration of the frame).
    pub fn with_legs_fixed(&self) -> Self {
        let mut problem = self.clone();
        problem.state = Arc::default();
        for group in &mut problem.groups {
            group.columns.clear();
        }
        problem
    }

    /// The same problem on the first `count` rows of every leg only.
    pub fn with_rows(&self, count: usize) -> Self {
        let mut problem = self.clone();
        problem.state = Arc::default();
        for group in &mut problem.groups {
            group.rows.truncate(count);
        }
        problem
    }

    /// The mechanism.
    pub fn mechanism(&self) -> &'a Mechanism {
        self.mechanism
    }

    /// The instrument.
    pub fn instrument(&self) -> &'a Instrument {
        self.instrument
    }

    /// Each group's measurement-file lines, one per row (`None` for simulated rows), in the
    /// residuals' order.
    pub fn row_lines(&self) -> Vec<Vec<Option<usize>>> {
        self.groups
            .iter()
            .map(|g| g.rows.iter().map(|r| r.line).collect())
            .collect()
    }

    /// Indices of the legs, one per group.
    pub fn legs(&self) -> Vec<usize> {
        self.groups.iter().map(|g| g.leg).collect()
    }

    /// Indices (into the instrument's parameters) of the identified shared parameters.
    pub fn shared_columns(&self) -> &[usize] {
        &self.shared
    }

    /// Names of the unknowns, in the order of `x`.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .groups
            .iter()
            .flat_map(|g| {
                let leg = &self.mechanism.legs[g.leg];
                g.columns.iter().map(|&c| leg.params[c].name.clone())
            })
            .collect();
        names.extend(
            self.shared
                .iter()
                .map(|&k| self.instrument.parameters[k].name.clone()),
        );
        names
    }

    /// The starting unknowns: the legs' nominal parameters, the shared ones at their held
    /// values (nominal unless [`Self::with_shared_fixed`] set them).
    pub fn start(&self) -> DVector<f64> {
        let mut x = Vec::new();
        for g in &self.groups {
            let leg = &self.mechanism.legs[g.leg];
            x.extend(g.columns.iter().map(|&c| leg.params[c].nominal));
        }
        x.extend(self.shared.iter().map(|&k| self.fixed[k]));
        DVector::from_vec(x)
    }

    /// Every shared parameter's value at `x` (the ones not identified at their held values).
    pub fn shared_values(&self, x: &DVector<f64>) -> Vec<f64> {
        self.shared_values_of(x.as_slice())
    }

    /// [`Self::shared_values`] of the unknowns `x` as a slice.
    fn shared_values_of(&self, x: &[f64]) -> Vec<f64> {
        let mut values = self.fixed.clone();
        let offset = x.len() - self.shared.len();
        for (i, &k) in self.shared.iter().enumerate() {
            values[k] = x[offset + i];
        }
        values
    }

    /// Every leg's full parameter vector at `x` (fixed parameters at nominal), one per group.
    pub fn leg_parameters(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        self.leg_parameters_of(x.as_slice())
    }

    /// [`Self::leg_parameters`] of the unknowns `x` as a slice.
    fn leg_parameters_of(&self, x: &[f64]) -> Vec<Vec<f64>> {
        let mut offset = 0;
        self.groups
            .iter()
            .map(|g| {
                let mut phi = self.mechanism.legs[g.leg].nominal();
                for (k, &c) in g.columns.iter().enumerate() {
                    phi[c] = x[offset + k];
                }
                offset += g.columns.len();
                phi
            })
            .collect()
    }

    /// The blocks, or only the residuals (empty derivative blocks) without `derivatives`.
    fn evaluate(
        &self,
        x: &DVector<f64>,
        derivatives: bool,
    ) -> std::result::Result<Vec<BorderedBlock>, ArgminError> {
        let phis = self.leg_parameters(x);
        let s = self.shared.len();
        self.evaluated(x.as_slice(), derivatives, |evaluation| {
            self.groups
                .iter()
                .zip(&phis)
                .zip(&evaluation.groups)
                .map(|((group, phi), values)| {
                    let leg = &self.mechanism.legs[group.leg];
                    let gain = leg.geometry(phi).gain;
                    let revolute = leg.actuated_is_revolute();
                    let gain_column = group
                        .columns
                        .iter()
                        .position(|&c| leg.params[c].target == ParamTarget::Gain);
                    let turn = turn_in_reading_units(gain);
                    let m = group.rows.len();
                    let mut block = match (&values.derivatives, derivatives) {
                        (Some((own, shared)), true) => BorderedBlock {
                            residuals: DVector::zeros(m),
                            own: own.clone(),
                            shared: shared.clone(),
                        },
                        _ => BorderedBlock {
                            residuals: DVector::zeros(m),
                            own: DMatrix::zeros(m, 0),
                            shared: DMatrix::zeros(m, 0),
                        },
                    };
                    for (i, (row, &predicted)) in
                        group.rows.iter().zip(&values.predicted).enumerate()
                    {
                        let n = turns(predicted, row.reading, gain, revolute);
                        block.residuals[i] = predicted - row.reading - n * turn;
                        if let (Some(k), true, true) = (gain_column, n != 0.0, derivatives) {
                            // d(−n·2π/gain)/d gain = n·2π/gain².
                            block.own[(i, k)] += n * turn / gain;
                        }
                    }
                    debug_assert!(!derivatives || block.shared.ncols() == s);
                    block
                })
                .collect()
        })
        .map_err(ArgminError::msg)
    }
}

impl Operator for SharedProblem<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    fn apply(&self, x: &DVector<f64>) -> std::result::Result<DVector<f64>, ArgminError> {
        let blocks = self.evaluate(x, false)?;
        let values: Vec<f64> = blocks
            .iter()
            .flat_map(|b| b.residuals.iter().copied())
            .collect();
        Ok(DVector::from_vec(values))
    }
}

impl BorderedLeastSquares for SharedProblem<'_> {
    fn layout(&self) -> BorderedLayout {
        BorderedLayout {
            own: self.groups.iter().map(|g| g.columns.len()).collect(),
            shared: self.shared.len(),
        }
    }

    fn bordered(&self, x: &DVector<f64>) -> std::result::Result<Vec<BorderedBlock>, ArgminError> {
        self.evaluate(x, true)
    }
}
