//! The evaluations of a [`SharedProblem`]: each row's fitted platform pose, inverse-kinematics
//! solution and predicted reading at one unknowns vector, and (once asked for) the reading's
//! derivatives; the latest two kept, keyed by the exact bits of the unknowns, as
//! [`crate::identify::problem::IdentificationProblem`] does for divide and conquer.
//!
//! A solver evaluates the blocks where it last evaluated the residuals: the blocks then cost
//! the derivative passes only. With respect to a leg's own parameters, the dual pass of
//! [`PreparedLeg`]. With respect to the shared parameters `s`, the chain rule through the
//! reading's Newton step: at a converged solution the reading is
//! `ψ = (q_a − Σ_k c_k (tip_k − X_k) − offset) / gain` (`c` the actuated row of the closure
//! Jacobian's inverse), and only the attachment's world position `X` depends on `s` (through
//! the fitted pose), so `∂ψ/∂s = Σ_k c_k ∂X_k/∂s / gain`, with `∂X/∂s` from one dual pass
//! through the pose fit and the attachment (no pass through the chain).

use nalgebra::{Const, DMatrix, U1};
use num_dual::{Dual64, DualSVec64};

use super::SharedProblem;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::chain::attachment_world;
use crate::kinematics::inverse::{Joints, Solution};
use crate::measure::targets::{platform_pose, platform_pose_from};
use crate::scalar::lift;

/// Latest evaluations kept (the solvers evaluate the blocks where they last evaluated the
/// residuals; the refinement may end on a rejected point after the estimate).
const KEPT_EVALUATIONS: usize = 2;

/// Lanes of one dual pass over the shared parameters in the pose fit.
const SHARED_LANES: usize = 8;

/// A problem's evaluation state: shared by its clones (a solver clones its problem and refines
/// on the original), which are evaluated one after the other, never at once.
#[derive(Debug, Default)]
pub(super) struct Evaluations {
    /// Per group, each row's joints at its last solved evaluation (`None` before the first):
    /// the warm start of its next inverse-kinematics solve.
    seeds: Vec<Vec<Option<Joints>>>,
    /// The latest evaluations, newest first.
    recent: Vec<Evaluation>,
}

/// The values of one evaluation, before turn matching: what any evaluation at the same
/// unknowns (bit for bit) returns without solving again.
#[derive(Debug)]
pub(super) struct Evaluation {
    /// The unknowns' bits.
    x: Vec<u64>,
    /// One per group.
    pub(super) groups: Vec<GroupValues>,
}

/// One group's rows at one evaluation.
#[derive(Debug)]
pub(super) struct GroupValues {
    /// Each row's inverse-kinematics solution at its fitted pose.
    pub(super) solutions: Vec<Solution>,
    /// Each row's predicted reading.
    pub(super) predicted: Vec<f64>,
    /// `∂ψ/∂own` (rows × own) and `∂ψ/∂shared` (rows × shared), without the turn matching's
    /// term; `None` until the derivatives are asked for.
    pub(super) derivatives: Option<(DMatrix<f64>, DMatrix<f64>)>,
}

/// The bits of `x`: evaluations are reused only at exactly the same unknowns.
fn key(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// `c_k / gain` for the closure's coordinates: the reading's derivative with respect to the
/// world position of the leg's attachment at a converged solution.
pub(super) fn attachment_gradient(
    actuated: usize,
    closure_dims: usize,
    gain: f64,
    solution: &Solution,
) -> [f64; 3] {
    let mut c = [0.0; 3];
    for (k, value) in c.iter_mut().enumerate().take(closure_dims) {
        *value = solution.closure_inverse[(actuated, k)] / gain;
    }
    c
}

impl SharedProblem<'_> {
    /// Calls `read` with the evaluation at the unknowns `x` (with the derivatives if
    /// `derivatives`): a kept one if there is one at exactly `x`, else a new one, which is then
    /// kept. Each row's inverse kinematics is warm-started from its last solution.
    ///
    /// # Errors
    /// The first row (in group order) whose leg cannot reach its fitted pose.
    pub(super) fn evaluated<R>(
        &self,
        x: &[f64],
        derivatives: bool,
        read: impl FnOnce(&Evaluation) -> R,
    ) -> Result<R, String> {
        let key = key(x);
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if state.seeds.len() != self.groups.len()
            || state
                .seeds
                .iter()
                .zip(&self.groups)
                .any(|(s, g)| s.len() != g.rows.len())
        {
            *state = Evaluations {
                seeds: self
                    .groups
                    .iter()
                    .map(|g| vec![None; g.rows.len()])
                    .collect(),
                recent: Vec::new(),
            };
        }
        let kept = state.recent.iter().position(|e| e.x == key);
        let shared = self.shared_values_of(x);
        let phis = self.leg_parameters_of(x);
        let mut evaluation = match kept {
            Some(i) => state.recent.remove(i),
            None => {
                let groups = state
                    .seeds
                    .iter_mut()
                    .enumerate()
                    .map(|(g, seeds)| self.solve_group(g, &phis[g], &shared, seeds))
                    .collect::<Result<_, _>>()?;
                Evaluation { x: key, groups }
            }
        };
        if derivatives {
            for (g, values) in evaluation.groups.iter_mut().enumerate() {
                if values.derivatives.is_none() {
                    values.derivatives = Some(self.group_derivatives(g, &phis[g], &shared, values));
                }
            }
        }
        let value = read(&evaluation);
        state.recent.insert(0, evaluation);
        state.recent.truncate(KEPT_EVALUATIONS);
        Ok(value)
    }

    /// Solves group `g`'s rows at leg parameters `phi` and shared values `shared`,
    /// warm-started from `seeds` (which then hold the new solutions).
    fn solve_group(
        &self,
        g: usize,
        phi: &[f64],
        shared: &[f64],
        seeds: &mut [Option<Joints>],
    ) -> Result<GroupValues, String> {
        let group = &self.groups[g];
        let leg = &self.mechanism.legs[group.leg];
        let home = &self.mechanism.home_pose;
        let prepared = PreparedLeg::new(leg, phi, &[]);
        let m = group.rows.len();
        let mut values = GroupValues {
            solutions: Vec::with_capacity(m),
            predicted: Vec::with_capacity(m),
            derivatives: None,
        };
        for (row, seed) in group.rows.iter().zip(seeds.iter_mut()) {
            let pose = platform_pose::<f64>(self.instrument, shared, &row.observed, home);
            let solution = prepared
                .solve_warm(&pose, home, seed.as_ref())
                .map_err(|source| {
                    let location = row
                        .line
                        .map_or(String::new(), |l| format!(" (measurement line {l})"));
                    format!(
                        "leg `{}` at the pose fitted from the targets{location}: {source}",
                        leg.name
                    )
                })?;
            *seed = Some(solution.q);
            values.predicted.push(prepared.reading_of(&solution));
            values.solutions.push(solution);
        }
        Ok(values)
    }

    /// Group `g`'s derivatives at its solved rows `values` (leg parameters `phi`, shared values
    /// `shared`): `∂ψ/∂own` by the prepared leg's dual pass, `∂ψ/∂shared` by the chain rule
    /// through the attachment's position.
    fn group_derivatives(
        &self,
        g: usize,
        phi: &[f64],
        shared: &[f64],
        values: &GroupValues,
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        let group = &self.groups[g];
        let leg = &self.mechanism.legs[group.leg];
        let home = &self.mechanism.home_pose;
        let prepared = PreparedLeg::new(leg, phi, &group.columns);
        let geometry = leg.geometry(phi);
        let (m, n, s) = (group.rows.len(), group.columns.len(), self.shared.len());
        let mut own = DMatrix::zeros(m, n);
        let mut border = DMatrix::zeros(m, s);
        let mut gradient = vec![0.0; n];
        let mut shared_row = vec![0.0; s];
        for (i, (row, solution)) in group.rows.iter().zip(&values.solutions).enumerate() {
            let pose = platform_pose::<f64>(self.instrument, shared, &row.observed, home);
            if n > 0 {
                prepared.reading_and_gradient_of(&pose, solution, &mut gradient);
                for (k, &v) in gradient.iter().enumerate() {
                    own[(i, k)] = v;
                }
            }
            if s > 0 {
                let c =
                    attachment_gradient(leg.actuated, leg.closure_dims, geometry.gain, solution);
                self.shared_gradient(
                    shared,
                    &row.observed,
                    &geometry.attachment,
                    &c,
                    &mut shared_row,
                );
                for (k, &v) in shared_row.iter().enumerate() {
                    border[(i, k)] = v;
                }
            }
        }
        (own, border)
    }

    /// `Σ_k c_k ∂X_k/∂s` for every identified shared parameter, into `out`: `X` the world
    /// position of `attachment` at the pose fitted from `observed` (dual passes of up to
    /// [`SHARED_LANES`] shared parameters).
    fn shared_gradient(
        &self,
        shared: &[f64],
        observed: &[f64],
        attachment: &[f64; 3],
        c: &[f64; 3],
        out: &mut [f64],
    ) {
        let home = &self.mechanism.home_pose;
        let attachment = attachment.map(lift::<DualSVec64<SHARED_LANES>>);
        for (chunk, out) in self
            .shared
            .chunks(SHARED_LANES)
            .zip(out.chunks_mut(SHARED_LANES))
        {
            let mut s: Vec<DualSVec64<SHARED_LANES>> =
                shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
            for (lane, &k) in chunk.iter().enumerate() {
                s[k] = s[k].derivative(lane);
            }
            let pose = platform_pose(self.instrument, &s, observed, home);
            let target = attachment_world(&pose, &attachment);
            let lanes: [_; 3] =
                std::array::from_fn(|k| target[k].eps.unwrap_generic(Const::<SHARED_LANES>, U1));
            for (lane, value) in out.iter_mut().enumerate() {
                *value = (0..3).map(|k| c[k] * lanes[k][lane]).sum();
            }
        }
    }

    /// The reading's derivative with respect to each of `observed`'s coordinates at a solved
    /// row (`c` from [`attachment_gradient`]), into `out`.
    pub(super) fn observed_gradient(
        &self,
        shared: &[f64],
        observed: &[f64],
        attachment: &[f64; 3],
        c: &[f64; 3],
        out: &mut [f64],
    ) {
        let home = &self.mechanism.home_pose;
        let lifted: Vec<Dual64> = shared.iter().map(|&v| Dual64::from(v)).collect();
        let attachment = attachment.map(lift::<Dual64>);
        let mut m: Vec<Dual64> = observed.iter().map(|&v| Dual64::from(v)).collect();
        for (i, value) in out.iter_mut().enumerate() {
            m[i] = m[i].derivative();
            let pose = platform_pose_from(self.instrument, &lifted, &m, home);
            m[i] = Dual64::from(observed[i]);
            let target = attachment_world(&pose, &attachment);
            *value = (0..3).map(|k| c[k] * target[k].eps).sum();
        }
    }
}
