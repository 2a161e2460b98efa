//! The evaluations of a [`SharedProblem`]: each row's fitted platform pose, inverse-kinematics
//! solution and predicted reading at one unknowns vector, and (once asked for) the reading's
//! derivatives; the latest two kept (problems of up to [`KEPT_ROWS`] rows), keyed by the exact
//! bits of the unknowns, as [`crate::identify::problem::IdentificationProblem`] does for
//! divide and conquer.
//!
//! A solver evaluates the blocks where it last evaluated the residuals: the blocks then cost
//! the derivative passes only. With respect to a leg's own parameters, the dual pass of
//! [`PreparedLeg`]. With respect to the shared parameters `s`, the chain rule through the
//! reading's Newton step: at a converged solution the reading is
//! `ψ = (q_a − Σ_k c_k (tip_k − X_k) − offset) / gain` (`c` the actuated row of the closure
//! Jacobian's inverse), and only the attachment's world position `X` depends on `s` (through
//! the fitted pose `P`), so `∂ψ/∂s = Σ_k c_k/gain · ∂X_k/∂P · ∂P/∂s`: `∂X/∂P` in closed form
//! ([`pose_gradient`]), `∂P/∂s` from the pose fit in dual numbers. No pass through the chain.

use nalgebra::{Const, DMatrix, U1};
use num_dual::{Dual64, DualSVec64};
use rayon::prelude::*;

use super::state::{key, Evaluation, Evaluations, GroupValues};
use super::SharedProblem;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::inverse::{Joints, Solution};
use crate::measure::targets::{platform_pose, platform_pose_from};

/// Latest evaluations kept (the solvers evaluate the blocks where they last evaluated the
/// residuals; the refinement may end on a rejected point after the estimate).
const KEPT_EVALUATIONS: usize = 2;

/// Largest problem (in rows, over all groups) whose evaluations are kept (about 200 bytes a
/// row each, with the derivatives); a larger one evaluates again at every call, warm-started.
const KEPT_ROWS: usize = 65_536;

/// Fewest rows (of the groups to evaluate) for which the groups are evaluated in parallel:
/// below, one group's evaluation takes tens of microseconds, and handing it to another thread
/// costs more than it saves on a busy machine.
const PARALLEL_ROWS: usize = 512;

/// Most lanes of one dual pass over the shared parameters in the pose fit (fewer shared
/// parameters take as many lanes as there are).
const SHARED_LANES: usize = 8;

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

/// Whether a group's evaluation has work to do: solving its rows (no kept `values`), or
/// computing their derivatives if `derivatives` are asked for and not kept.
fn has_work(values: Option<&GroupValues>, derivatives: bool) -> bool {
    values.is_none_or(|v| derivatives && v.derivatives.is_none())
}

/// Whether groups with work to do of `rows` rows each are evaluated in parallel (rayon): when
/// more than one has work and there are enough rows to pay for handing them to other threads.
fn in_parallel(rows: &[usize]) -> bool {
    rows.len() > 1 && rows.iter().sum::<usize>() >= PARALLEL_ROWS
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
                row_solves: state.row_solves,
            };
        }
        let kept = state.recent.iter().position(|e| e.x == key);
        let shared = self.shared_values_of(x);
        let phis = self.leg_parameters_of(x);
        let mut kept: Vec<Option<GroupValues>> = match kept {
            Some(i) => state
                .recent
                .remove(i)
                .groups
                .into_iter()
                .map(Some)
                .collect(),
            None => self.groups.iter().map(|_| None).collect(),
        };
        let work = |g: usize, seeds: &mut [Option<Joints>], values: Option<GroupValues>| {
            let mut values = match values {
                Some(values) => values,
                None => self.solve_group(g, &phis[g], &shared, seeds)?,
            };
            if has_work(Some(&values), derivatives) {
                values.derivatives = Some(self.group_derivatives(g, &phis[g], &shared, &values));
            }
            Ok::<_, String>(values)
        };
        // The rows of the groups without kept values: solved below.
        let solving: usize = kept
            .iter()
            .zip(&self.groups)
            .filter(|(v, _)| v.is_none())
            .map(|(_, group)| group.rows.len())
            .sum();
        let pending: Vec<usize> = kept
            .iter()
            .zip(&self.groups)
            .filter(|(v, _)| has_work(v.as_ref(), derivatives))
            .map(|(_, group)| group.rows.len())
            .collect();
        // Each group's values depend only on its own rows and seeds, so not on the number of
        // threads. The first error in group order.
        let results: Vec<Result<GroupValues, String>> = if in_parallel(&pending) {
            state
                .seeds
                .par_iter_mut()
                .zip(kept.par_iter_mut())
                .enumerate()
                .map(|(g, (seeds, values))| work(g, seeds, values.take()))
                .collect()
        } else {
            state
                .seeds
                .iter_mut()
                .zip(kept.iter_mut())
                .enumerate()
                .map(|(g, (seeds, values))| work(g, seeds, values.take()))
                .collect()
        };
        let groups = results.into_iter().collect::<Result<_, _>>()?;
        state.row_solves += solving as u64;
        let evaluation = Evaluation { x: key, groups };
        let value = read(&evaluation);
        if self.groups.iter().map(|g| g.rows.len()).sum::<usize>() <= KEPT_ROWS {
            state.recent.insert(0, evaluation);
            state.recent.truncate(KEPT_EVALUATIONS);
        }
        Ok(value)
    }

    /// How many rows' inverse kinematics this problem and its clones have solved so far (a
    /// row solved at several evaluations counts each time): an evaluation at unknowns where one
    /// is kept solves no row, and its derivatives where the residuals were evaluated need the
    /// derivative passes only.
    pub fn row_solves(&self) -> u64 {
        self.state
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .row_solves
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
            poses: Vec::with_capacity(m),
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
            values.poses.push(pose);
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
        let prepared = PreparedLeg::new(leg, phi, &group.columns);
        let (m, n) = (group.rows.len(), group.columns.len());
        let mut own = DMatrix::zeros(m, n);
        let mut gradient = vec![0.0; n];
        // A held leg (the instrument's registration stage) has no column: no dual pass.
        if !group.columns.is_empty() {
            for (i, (pose, solution)) in values.poses.iter().zip(&values.solutions).enumerate() {
                prepared.reading_and_gradient_of(pose, solution, &mut gradient);
                for (k, &v) in gradient.iter().enumerate() {
                    own[(i, k)] = v;
                }
            }
        }
        let border = self.border_columns(g, phi, shared, values);
        (own, border)
    }

    /// Group `g`'s `∂ψ/∂shared` (rows × identified shared parameters): per row,
    /// `Σ_k c_k ∂X_k/∂s` with `X` the world position of the leg's attachment at the pose fitted
    /// from the row's targets, by dual passes of up to [`SHARED_LANES`] shared parameters
    /// through the pose fit and the attachment.
    fn border_columns(
        &self,
        g: usize,
        phi: &[f64],
        shared: &[f64],
        values: &GroupValues,
    ) -> DMatrix<f64> {
        let group = &self.groups[g];
        if self.shared.is_empty() {
            // Every shared parameter held (the legs' stage of the two-stage alternative): no
            // column, and no pose derivative to compute for it.
            return DMatrix::zeros(group.rows.len(), 0);
        }
        let leg = &self.mechanism.legs[group.leg];
        let geometry = leg.geometry(phi);
        // Per row, the reading's derivative with respect to the fitted pose (the same for
        // every pass).
        let pose_derivatives: Vec<[f64; 6]> = values
            .poses
            .iter()
            .zip(&values.solutions)
            .map(|(pose, solution)| {
                let c =
                    attachment_gradient(leg.actuated, leg.closure_dims, geometry.gain, solution);
                pose_gradient(&c, pose, &geometry.attachment)
            })
            .collect();
        let mut border = DMatrix::zeros(group.rows.len(), self.shared.len());
        let passes = (0..self.shared.len()).step_by(SHARED_LANES);
        for first in passes {
            let rows = (g, shared, &pose_derivatives[..]);
            match (self.shared.len() - first).min(SHARED_LANES) {
                1 => self.border_pass::<1>(rows, first, &mut border),
                2 => self.border_pass::<2>(rows, first, &mut border),
                3 => self.border_pass::<3>(rows, first, &mut border),
                4 => self.border_pass::<4>(rows, first, &mut border),
                5 => self.border_pass::<5>(rows, first, &mut border),
                6 => self.border_pass::<6>(rows, first, &mut border),
                7 => self.border_pass::<7>(rows, first, &mut border),
                _ => self.border_pass::<SHARED_LANES>(rows, first, &mut border),
            }
        }
        border
    }

    /// The `N` border columns from `first` on, by one dual pass seeding the identified shared
    /// parameters `first..first + N` (exactly `N` of them), through group `g`'s pose fits:
    /// column `first + lane` of row `i` is `Σ_k d_ik ∂P_k/∂s_lane`, with `d_i` the row's
    /// reading derivative with respect to its fitted pose.
    fn border_pass<const N: usize>(
        &self,
        (g, shared, pose_derivatives): (usize, &[f64], &[[f64; 6]]),
        first: usize,
        border: &mut DMatrix<f64>,
    ) {
        let home = &self.mechanism.home_pose;
        let mut seeded: Vec<DualSVec64<N>> =
            shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
        for lane in 0..N {
            let k = self.shared[first + lane];
            seeded[k] = seeded[k].derivative(lane);
        }
        let rows = self.groups[g].rows.iter().zip(pose_derivatives);
        for (i, (row, d)) in rows.enumerate() {
            let fitted = platform_pose(self.instrument, &seeded, &row.observed, home);
            let lanes: [_; 6] =
                std::array::from_fn(|k| fitted[k].eps.unwrap_generic(Const::<N>, U1));
            for lane in 0..N {
                border[(i, first + lane)] = (0..6).map(|k| d[k] * lanes[k][lane]).sum();
            }
        }
    }

    /// The reading's derivative with respect to each of `observed`'s coordinates at a solved
    /// row (`c` from [`attachment_gradient`], `pose` the row's fitted pose), into `out`.
    pub(super) fn observed_gradient(
        &self,
        shared: &[f64],
        observed: &[f64],
        (pose, attachment): (&[f64; 6], &[f64; 3]),
        c: &[f64; 3],
        out: &mut [f64],
    ) {
        let home = &self.mechanism.home_pose;
        let d = pose_gradient(c, pose, attachment);
        let lifted: Vec<Dual64> = shared.iter().map(|&v| Dual64::from(v)).collect();
        let mut m: Vec<Dual64> = observed.iter().map(|&v| Dual64::from(v)).collect();
        for (i, value) in out.iter_mut().enumerate() {
            m[i] = m[i].derivative();
            let fitted = platform_pose_from(self.instrument, &lifted, &m, home);
            m[i] = Dual64::from(observed[i]);
            *value = (0..6).map(|k| d[k] * fitted[k].eps).sum();
        }
    }
}

/// `∂ψ/∂P`, the reading's derivative with respect to the platform pose
/// `P = [x, y, z, roll, pitch, yaw]` at `pose`, from `c = ∂ψ/∂X` (the attachment's world
/// position `X = p + R(P) a`, [`attachment_gradient`]) and the attachment `a` in the platform
/// frame: `∂X/∂p = I`, and with `R = R_z(yaw) R_y(pitch) R_x(roll)` (the platform transform's
/// convention), `∂X/∂roll = R_z R_y (e_x × R_x a)`, `∂X/∂pitch = R_z (e_y × R_y R_x a)`,
/// `∂X/∂yaw = e_z × R a`.
pub(super) fn pose_gradient(c: &[f64; 3], pose: &[f64; 6], attachment: &[f64; 3]) -> [f64; 6] {
    let (sr, cr) = pose[3].sin_cos();
    let (sp, cp) = pose[4].sin_cos();
    let (sy, cy) = pose[5].sin_cos();
    let rx = |v: [f64; 3]| [v[0], cr * v[1] - sr * v[2], sr * v[1] + cr * v[2]];
    let ry = |v: [f64; 3]| [cp * v[0] + sp * v[2], v[1], -sp * v[0] + cp * v[2]];
    let rz = |v: [f64; 3]| [cy * v[0] - sy * v[1], sy * v[0] + cy * v[1], v[2]];
    let dot = |v: [f64; 3]| c[0] * v[0] + c[1] * v[1] + c[2] * v[2];
    let a1 = rx(*attachment);
    let a2 = ry(a1);
    let a3 = rz(a2);
    // e_x × v = (0, −v_z, v_y); e_y × v = (v_z, 0, −v_x); e_z × v = (−v_y, v_x, 0).
    let roll = rz(ry([0.0, -a1[2], a1[1]]));
    let pitch = rz([a2[2], 0.0, -a2[0]]);
    let yaw = [-a3[1], a3[0], 0.0];
    [c[0], c[1], c[2], dot(roll), dot(pitch), dot(yaw)]
}

#[cfg(test)]
mod tests {
    use nalgebra::{Const, U1};
    use num_dual::DualSVec64;

    use super::{has_work, in_parallel, pose_gradient, GroupValues, PARALLEL_ROWS};
    use crate::kinematics::chain::attachment_world;

    /// Kept values of a group without rows, with or without their derivatives.
    fn kept(with_derivatives: bool) -> GroupValues {
        GroupValues {
            poses: Vec::new(),
            solutions: Vec::new(),
            predicted: Vec::new(),
            derivatives: with_derivatives.then(|| {
                (
                    nalgebra::DMatrix::zeros(0, 0),
                    nalgebra::DMatrix::zeros(0, 0),
                )
            }),
        }
    }

    #[test]
    fn a_group_has_work_without_kept_values_or_without_the_derivatives_asked_for() {
        for derivatives in [false, true] {
            assert!(has_work(None, derivatives), "nothing kept: solve");
            assert!(!has_work(Some(&kept(true)), derivatives), "everything kept");
        }
        assert!(
            !has_work(Some(&kept(false)), false),
            "values kept, no derivatives asked"
        );
        assert!(
            has_work(Some(&kept(false)), true),
            "derivatives asked, not kept"
        );
    }

    #[test]
    fn groups_go_to_the_thread_pool_when_several_have_enough_rows_in_all() {
        let half = PARALLEL_ROWS / 2;
        assert!(in_parallel(&[half, half]));
        assert!(in_parallel(&[1, 1, PARALLEL_ROWS - 2]));
        assert!(!in_parallel(&[half, half - 1]), "too few rows");
        assert!(!in_parallel(&[10 * PARALLEL_ROWS]), "one group");
        assert!(!in_parallel(&[]));
    }

    #[test]
    fn the_pose_gradient_is_the_dual_derivative_of_the_attachments_world_position() {
        let c = [0.3, -1.7, 0.9];
        let attachment = [0.12, -0.05, 0.31];
        for pose in [
            [0.1, 1.2, 0.0, 0.0, 0.0, 0.4],
            [0.3, -0.2, 0.7, 0.25, -0.6, 2.9],
            [-1.0, 0.5, 0.2, -1.2, 1.1, -0.3],
        ] {
            let seeded: [DualSVec64<6>; 6] =
                std::array::from_fn(|k| DualSVec64::from_re(pose[k]).derivative(k));
            let a = attachment.map(DualSVec64::<6>::from_re);
            let x = attachment_world(&seeded, &a);
            let d = pose_gradient(&c, &pose, &attachment);
            for (k, value) in d.iter().enumerate() {
                let expected: f64 = (0..3)
                    .map(|i| c[i] * x[i].eps.unwrap_generic(Const::<6>, U1)[k])
                    .sum();
                assert!(
                    (value - expected).abs() <= 1e-14,
                    "pose {pose:?}, coordinate {k}: {value} against {expected}"
                );
            }
        }
    }
}
