//! A problem that sees the platform through an instrument: each block's platform pose is
//! fitted from its targets' coordinates at the current shared parameters `s` (the instrument's
//! frame and target offsets, [`platform_pose`]), and `s` are unknowns beside the legs'.
//!
//! The reading's derivatives with respect to `s`: at a converged solution the reading is
//! `ψ = (q_a − Σ_k c_k (tip_k − X_k) − offset) / gain` (`c` the actuated row of the closure
//! Jacobian's inverse), and only the attachment's world position `X` depends on `s` (through
//! the fitted pose `P`), so `∂ψ/∂s = Σ_k c_k/gain · ∂X_k/∂P · ∂P/∂s`: `∂X/∂P` in closed form
//! ([`pose_gradient`]), `∂P/∂s` from the pose fit in dual numbers. No pass through the chain.
//! The same chain rule with respect to the target coordinates gives how the instrument's
//! noise reaches each residual (problem/noise.rs, docs/method.md §13).

use std::sync::Arc;

use nalgebra::{Const, U1};
use num_dual::{Dual64, DualSVec64};

use crate::identify::jacobian::{PreparedLeg, LANES};
use crate::kinematics::inverse::Solution;
use crate::measure::targets::{platform_pose, platform_pose_from};
use crate::model::instrument::Instrument;

/// The instrument's part of a problem.
#[derive(Debug, Clone)]
pub(super) struct Sighted<'a> {
    pub(super) instrument: &'a Instrument,
    /// Indices (into the instrument's parameters) of the identified shared parameters: the
    /// problem's last unknowns.
    pub(super) shared: Vec<usize>,
    /// Every shared value; the ones not identified are held there (nominal unless set).
    pub(super) held: Vec<f64>,
    /// Per block, what the instrument saw (shared by the problem's clones).
    pub(super) rows: Arc<Vec<Sighting>>,
}

/// What the instrument saw at one block.
#[derive(Debug, Clone)]
pub(super) struct Sighting {
    /// The row's index in the observations: the blocks of several legs with the same index
    /// are one measurement, whose target noise reaches every leg's residual.
    pub(super) source: usize,
    /// The targets' coordinates.
    pub(super) observed: Vec<f64>,
}

/// `c_k / gain` for the closure's coordinates: the reading's derivative with respect to the
/// world position of the leg's attachment at a converged solution.
fn attachment_gradient(leg: &PreparedLeg<'_>, solution: &Solution) -> [f64; 3] {
    let model = leg.leg();
    let mut c = [0.0; 3];
    for (k, value) in c.iter_mut().enumerate().take(model.closure_dims) {
        *value = solution.closure_inverse[(model.actuated, k)] / leg.geometry().gain;
    }
    c
}

/// The reading's derivative with respect to the fitted pose at a solved row.
pub(super) fn reading_pose_gradient(
    leg: &PreparedLeg<'_>,
    pose: &[f64; 6],
    solution: &Solution,
) -> [f64; 6] {
    let c = attachment_gradient(leg, solution);
    pose_gradient(&c, pose, &leg.geometry().attachment)
}

impl Sighted<'_> {
    /// The values of every shared parameter at the unknowns `x` (the identified ones last).
    pub(super) fn values(&self, x: &[f64]) -> Vec<f64> {
        let mut values = self.held.clone();
        let offset = x.len() - self.shared.len();
        for (i, &k) in self.shared.iter().enumerate() {
            values[k] = x[offset + i];
        }
        values
    }

    /// One row's `∂ψ/∂s` over the identified shared parameters, into `out`: per pass of up to
    /// [`LANES`] of them, `Σ_k d_k ∂P_k/∂s_lane` with `d` the reading's derivative with
    /// respect to the pose fitted from `observed` (at `pose`), `∂P/∂s` by one dual pass
    /// through the pose fit.
    pub(super) fn shared_gradient(
        &self,
        leg: &PreparedLeg<'_>,
        (observed, pose): (&[f64], &[f64; 6]),
        solution: &Solution,
        (shared, home): (&[f64], &[f64; 6]),
        out: &mut [f64],
    ) {
        let d = reading_pose_gradient(leg, pose, solution);
        for first in (0..self.shared.len()).step_by(LANES) {
            let row = (observed, &d, first);
            match (self.shared.len() - first).min(LANES) {
                1 => self.shared_pass::<1>(row, (shared, home), out),
                2 => self.shared_pass::<2>(row, (shared, home), out),
                3 => self.shared_pass::<3>(row, (shared, home), out),
                4 => self.shared_pass::<4>(row, (shared, home), out),
                5 => self.shared_pass::<5>(row, (shared, home), out),
                6 => self.shared_pass::<6>(row, (shared, home), out),
                7 => self.shared_pass::<7>(row, (shared, home), out),
                _ => self.shared_pass::<LANES>(row, (shared, home), out),
            }
        }
    }

    /// The `N` shared columns from `first` on, by one dual pass seeding the identified shared
    /// parameters `first..first + N` (exactly `N` of them) through the pose fit of `observed`.
    fn shared_pass<const N: usize>(
        &self,
        (observed, d, first): (&[f64], &[f64; 6], usize),
        (shared, home): (&[f64], &[f64; 6]),
        out: &mut [f64],
    ) {
        let mut seeded: Vec<DualSVec64<N>> =
            shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
        for lane in 0..N {
            let k = self.shared[first + lane];
            seeded[k] = seeded[k].derivative(lane);
        }
        let fitted = platform_pose(self.instrument, &seeded, observed, home);
        let lanes: [_; 6] = std::array::from_fn(|k| fitted[k].eps.unwrap_generic(Const::<N>, U1));
        for lane in 0..N {
            out[first + lane] = (0..6).map(|k| d[k] * lanes[k][lane]).sum();
        }
    }

    /// The reading's derivative with respect to each of `observed`'s coordinates at a solved
    /// row (`d` its derivative with respect to the fitted pose), into `out`.
    pub(super) fn observed_gradient(
        &self,
        (shared, home): (&[f64], &[f64; 6]),
        observed: &[f64],
        d: &[f64; 6],
        out: &mut [f64],
    ) {
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
fn pose_gradient(c: &[f64; 3], pose: &[f64; 6], attachment: &[f64; 3]) -> [f64; 6] {
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

    use super::pose_gradient;
    use crate::kinematics::chain::attachment_world;

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
