//! The identification with the instrument's shared parameters: every leg's own parameters
//! plus the frame and target offsets, which all legs share (a bordered block-diagonal least
//! squares problem, [`BorderedLeastSquares`]).
//!
//! At row `j` of leg `i`, the platform pose is fitted from the row's target coordinates at the
//! current shared parameters `s` ([`platform_pose`]), and the residual is the leg's reading
//! residual at that pose (matched modulo one turn as in [`super::problem`]). Its derivatives:
//! with respect to the leg's own parameters, the dual pass of [`PreparedLeg`]; with respect to
//! `s`, the chain rule `∂ψ/∂P · ∂P/∂s`, both factors from dual numbers (the pose gradient of the
//! reading in one static-dual pass over the six pose coordinates, `∂P/∂s` by seeding one shared
//! parameter at a time in the pose fit). Each leg's rows are one group: divide and conquer's
//! per-leg structure is kept, and a Schur-complement Levenberg–Marquardt factors each leg's
//! block on its own ([`crate::solver::solve_bordered`]).

use std::sync::Mutex;

use argmin::core::{Error as ArgminError, Operator};
use nalgebra::{Const, DMatrix, DVector, U1};
use num_dual::{Dual64, DualSVec64};

use super::jacobian::PreparedLeg;
use super::residual::{turn_in_reading_units, turns};
use crate::error::{Error, Result};
use crate::kinematics::chain::{attachment_world, ChainFrames};
use crate::kinematics::inverse::{reading_at, reading_at_solution, Joints};
use crate::measure::observations::{instrument_of, Observations};
use crate::measure::targets::{platform_pose, platform_pose_from};
use crate::model::instrument::Instrument;
use crate::model::mechanism::MeasurementNoise;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;
use crate::solver::bordered::{BorderedBlock, BorderedLayout, BorderedLeastSquares};

/// One row of one leg: the targets' coordinates and the leg's reading.
#[derive(Debug, Clone)]
struct Row {
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
    /// Each row's last inverse-kinematics solution, the warm start of its next evaluation.
    warm: WarmStarts,
}

/// Per group, each row's joints at its last solved evaluation (`None` before the first). A
/// value of its problem: a clone copies it.
#[derive(Debug, Default)]
struct WarmStarts(Mutex<Vec<Vec<Option<Joints>>>>);

impl Clone for WarmStarts {
    fn clone(&self) -> Self {
        let seeds = self.0.lock().unwrap_or_else(|e| e.into_inner());
        Self(Mutex::new(seeds.clone()))
    }
}

/// Lanes of one dual pass over the shared parameters in the pose fit.
const SHARED_LANES: usize = 8;

/// What one row's evaluation produces.
struct RowValue {
    residual: f64,
    own: Vec<f64>,
    shared: Vec<f64>,
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
                .leg_rows(leg)
                .into_iter()
                .map(|(row, reading)| Row {
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
            warm: WarmStarts::default(),
        })
    }

    /// The same problem with every shared parameter held at `values` (all of them, in the
    /// instrument's order): the legs separate again (the two-stage alternative's second stage,
    /// or a frame taken as known).
    pub fn with_shared_fixed(&self, values: &[f64]) -> Self {
        Self {
            shared: Vec::new(),
            fixed: values.to_vec(),
            ..self.clone()
        }
    }

    /// The same problem with every leg parameter held at its nominal value: only the shared
    /// parameters are unknown (the two-stage alternative's registration of the frame).
    pub fn with_legs_fixed(&self) -> Self {
        let mut problem = self.clone();
        for group in &mut problem.groups {
            group.columns.clear();
        }
        problem
    }

    /// The same problem on the first `count` rows of every leg only.
    pub fn with_rows(&self, count: usize) -> Self {
        let mut problem = self.clone();
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
        let mut values = self.fixed.clone();
        let offset = x.len() - self.shared.len();
        for (i, &k) in self.shared.iter().enumerate() {
            values[k] = x[offset + i];
        }
        values
    }

    /// Every leg's full parameter vector at `x` (fixed parameters at nominal), one per group.
    pub fn leg_parameters(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
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

    /// Residuals, and (if `derivatives`) the Jacobian rows, of group `g` at leg parameters
    /// `phi` and all shared values `shared`.
    fn group_rows(
        &self,
        g: usize,
        phi: &[f64],
        shared: &[f64],
        derivatives: bool,
    ) -> std::result::Result<Vec<RowValue>, ArgminError> {
        let group = &self.groups[g];
        let leg = &self.mechanism.legs[group.leg];
        let home = &self.mechanism.home_pose;
        let columns: &[usize] = if derivatives { &group.columns } else { &[] };
        let prepared = PreparedLeg::new(leg, phi, columns);
        let lifted_phi: Vec<DualSVec64<SHARED_LANES>> =
            phi.iter().map(|&v| DualSVec64::from_re(v)).collect();
        let lifted = leg.geometry(&lifted_phi);
        let frames = ChainFrames::new(&lifted);
        let gain = leg.geometry(phi).gain;
        let revolute = leg.actuated_is_revolute();
        let gain_column = group
            .columns
            .iter()
            .position(|&c| leg.params[c].target == ParamTarget::Gain);
        let mut warm = self.warm.0.lock().unwrap_or_else(|e| e.into_inner());
        if warm.len() != self.groups.len() {
            *warm = self
                .groups
                .iter()
                .map(|g| vec![None; g.rows.len()])
                .collect();
        }
        let seeds = &mut warm[g];
        seeds.resize(group.rows.len(), None);
        group
            .rows
            .iter()
            .zip(seeds.iter_mut())
            .map(|(row, seed)| {
                let pose = platform_pose::<f64>(self.instrument, shared, &row.observed, home);
                let solution =
                    prepared
                        .solve_warm(&pose, home, seed.as_ref())
                        .map_err(|source| {
                            let location = row
                                .line
                                .map_or(String::new(), |l| format!(" (measurement line {l})"));
                            ArgminError::msg(format!(
                                "leg `{}` at the pose fitted from the targets{location}: {source}",
                                leg.name
                            ))
                        })?;
                *seed = Some(solution.q);
                let mut own = vec![0.0; columns.len()];
                let predicted = if derivatives {
                    prepared.reading_and_gradient_of(&pose, &solution, &mut own)
                } else {
                    prepared.reading_of(&solution)
                };
                let n = turns(predicted, row.reading, gain, revolute);
                let turn = turn_in_reading_units(gain);
                if let (Some(k), true, true) = (gain_column, n != 0.0, derivatives) {
                    own[k] += n * turn / gain;
                }
                let residual = predicted - row.reading - n * turn;
                let mut shared_row = Vec::new();
                if derivatives {
                    // ∂ψ/∂s: the pose fit and the reading's Newton step in one dual pass, up to
                    // eight shared parameters on their own lanes (the chain frames lifted once).
                    for chunk in self.shared.chunks(SHARED_LANES) {
                        let mut s: Vec<DualSVec64<SHARED_LANES>> =
                            shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
                        for (lane, &k) in chunk.iter().enumerate() {
                            s[k] = s[k].derivative(lane);
                        }
                        let pose = platform_pose(self.instrument, &s, &row.observed, home);
                        let target = attachment_world(&pose, &lifted.attachment);
                        let reading = reading_at(leg, &frames, &lifted, &target, &solution);
                        let lanes = reading.eps.unwrap_generic(Const::<SHARED_LANES>, U1);
                        shared_row.extend(lanes.iter().take(chunk.len()));
                    }
                }
                Ok(RowValue {
                    residual,
                    own,
                    shared: shared_row,
                })
            })
            .collect()
    }

    /// Expected variance of every residual at `x` (rows in group order) under the declared
    /// `noise`: `σ_q² + Σ_i (∂ψ/∂m_i)² σ_i²` over the row's target coordinates `m_i` (σ of the
    /// coordinate of the same name: x, y, z, roll, pitch, yaw), `∂ψ/∂m_i = ∂ψ/∂P · ∂P/∂m_i` by
    /// dual numbers.
    ///
    /// # Errors
    /// A leg cannot reach a fitted pose.
    pub fn row_variances(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> std::result::Result<Vec<f64>, ArgminError> {
        let shared = self.shared_values(x);
        let lifted: Vec<Dual64> = shared.iter().map(|&v| Dual64::from(v)).collect();
        let sigmas: Vec<f64> = self
            .instrument
            .targets
            .iter()
            .flat_map(|t| t.pose_indices())
            .map(|&c| noise.pose[c])
            .collect();
        let home = &self.mechanism.home_pose;
        let mut variances = Vec::new();
        let warm = self
            .warm
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        for (g, (group, phi)) in self.groups.iter().zip(self.leg_parameters(x)).enumerate() {
            let leg = &self.mechanism.legs[group.leg];
            let prepared = PreparedLeg::new(leg, &phi, &[]);
            let dual_phi: Vec<DualSVec64<6>> =
                phi.iter().map(|&v| DualSVec64::from_re(v)).collect();
            let dual_geometry = leg.geometry(&dual_phi);
            for (j, row) in group.rows.iter().enumerate() {
                let pose = platform_pose::<f64>(self.instrument, &shared, &row.observed, home);
                let seed = warm.get(g).and_then(|w| w.get(j)).and_then(Option::as_ref);
                let solution = prepared
                    .solve_warm(&pose, home, seed)
                    .map_err(|e| ArgminError::msg(format!("leg `{}`: {e}", leg.name)))?;
                let seeded: [DualSVec64<6>; 6] =
                    std::array::from_fn(|c| DualSVec64::from_re(pose[c]).derivative(c));
                let at = solution.to_leg_solution(leg);
                let reading = reading_at_solution(leg, &dual_geometry, &seeded, &at);
                let lanes = reading.eps.unwrap_generic(Const::<6>, U1);
                let mut variance = noise.reading.powi(2);
                for (i, sigma) in sigmas.iter().enumerate() {
                    let mut m: Vec<Dual64> =
                        row.observed.iter().map(|&v| Dual64::from(v)).collect();
                    m[i] = m[i].derivative();
                    let dp = platform_pose_from(self.instrument, &lifted, &m, home);
                    let d: f64 = (0..6).map(|c| lanes[c] * dp[c].eps).sum();
                    variance += (d * sigma).powi(2);
                }
                variances.push(variance);
            }
        }
        Ok(variances)
    }

    /// The blocks, or only the residuals (empty derivative blocks) without `derivatives`.
    fn evaluate(
        &self,
        x: &DVector<f64>,
        derivatives: bool,
    ) -> std::result::Result<Vec<BorderedBlock>, ArgminError> {
        let shared = self.shared_values(x);
        let phis = self.leg_parameters(x);
        let s = self.shared.len();
        (0..self.groups.len())
            .map(|g| {
                let rows = self.group_rows(g, &phis[g], &shared, derivatives)?;
                let m = rows.len();
                let n = if derivatives {
                    self.groups[g].columns.len()
                } else {
                    0
                };
                let width = if derivatives { s } else { 0 };
                let mut block = BorderedBlock {
                    residuals: DVector::zeros(m),
                    own: DMatrix::zeros(m, n),
                    shared: DMatrix::zeros(m, width),
                };
                for (i, row) in rows.iter().enumerate() {
                    block.residuals[i] = row.residual;
                    for (j, v) in row.own.iter().enumerate() {
                        block.own[(i, j)] = *v;
                    }
                    for (j, v) in row.shared.iter().enumerate() {
                        block.shared[(i, j)] = *v;
                    }
                }
                Ok(block)
            })
            .collect()
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
