//! What the instrument sees of a platform pose, and the platform pose from what it sees.
//!
//! The instrument frame `F = (f, θ_f)` sits in the base frame; target `k` sits at offset `t_k`
//! in the platform frame. At platform pose `P = (p, ψ)` the instrument reports target `k` at
//! `m_k = R(θ_f)ᵀ (p + R(ψ) t_k − f)` (and, for a pose target, its orientation `ψ − θ_f`):
//! [`observe`]. Back, [`platform_pose`] fits `P` from one row's `m_k` at the current shared
//! parameters `s = (f, θ_f, t_1, …)`: every target's position in the base frame is
//! `q_k = f + R(θ_f) m_k`; the platform's orientation is the circular mean of the pose targets'
//! orientations if there are any, else the planar Procrustes angle
//! `ψ = atan2(Σ a_k × b_k, Σ a_k · b_k)` between the offsets and the positions, each taken from
//! its centroid (for two targets: the angle between the offset segment and the measured one);
//! a platform that does not rotate keeps its home orientation. The position is then the
//! least-squares `p = mean_k (q_k − R(ψ) t_k)`.
//!
//! A spatial instrument (6-DoF frame, 3-D offsets) is the same in three dimensions: the
//! orientation is then fitted by Horn's quaternion method (`spatial`, `horn`).
//!
//! [`platform_pose`] is written once, generic over [`Scalar`]: run on dual numbers seeded in
//! `s`, it gives `∂P/∂s`, the chain-rule factor of the identification's shared columns.

mod horn;
mod spatial;

pub use spatial::{observe_framed, platform_rotation, Frame as SpatialFrame};

use crate::model::instrument::{Instrument, Measures};
use crate::scalar::{lift, Scalar};

/// The instrument's report of every target at platform pose `pose` with shared parameters
/// `shared` (layout of [`Instrument`]), in measurement-row order.
pub fn observe(instrument: &Instrument, shared: &[f64], pose: &[f64; 6]) -> Vec<f64> {
    observe_in(instrument, shared, pose)
}

/// [`observe`] in any scalar type: run on dual numbers seeded in the pose and the shared
/// parameters, it gives the derivatives of a forward row's prediction.
pub fn observe_in<T: Scalar>(instrument: &Instrument, shared: &[T], pose: &[T; 6]) -> Vec<T> {
    if instrument.spatial {
        return spatial::observe(instrument, shared, pose);
    }
    let (fx, fy, theta) = (
        shared[Instrument::FRAME],
        shared[Instrument::FRAME + 1],
        shared[Instrument::FRAME + 2],
    );
    let (s, c) = (theta.sin(), theta.cos());
    let (ps, pc) = (pose[5].sin(), pose[5].cos());
    let mut observed = Vec::with_capacity(instrument.observed_len());
    for (k, target) in instrument.targets.iter().enumerate() {
        let o = instrument.offset_index(k);
        let (tx, ty) = (shared[o], shared[o + 1]);
        let qx = pose[0] + pc * tx - ps * ty - fx;
        let qy = pose[1] + ps * tx + pc * ty - fy;
        let m = [c * qx + s * qy, -s * qx + c * qy];
        match target.measures {
            Measures::Coordinates(_) => {
                observed.extend(target.pose_indices().iter().map(|&i| m[i]));
            }
            _ => observed.extend(m),
        }
        if target.measures == Measures::Pose {
            observed.push(pose[5] - theta);
        }
    }
    observed
}

/// Target `target`'s position in the base frame at platform pose `pose`, its offset from the
/// shared parameters `shared`: `p + R(pose) t` (a planar target's offset lies in the plane).
pub fn target_position<T: Scalar>(
    instrument: &Instrument,
    shared: &[T],
    target: usize,
    pose: &[T; 6],
) -> [T; 3] {
    let o = instrument.offset_index(target);
    let zero = lift::<T>(0.0);
    let offset = if instrument.spatial {
        [shared[o], shared[o + 1], shared[o + 2]]
    } else {
        [shared[o], shared[o + 1], zero]
    };
    let moved = crate::kinematics::chain::attachment_world(pose, &offset);
    [moved[0], moved[1], moved[2]]
}

/// Target `target`'s position in the instrument frame (all its coordinates, reported or not)
/// at platform pose `pose`: `R_fᵀ (X − f)`, `X` its base-frame position ([`target_position`]).
pub fn target_in_frame<T: Scalar>(
    instrument: &Instrument,
    shared: &[T],
    target: usize,
    pose: &[T; 6],
) -> [T; 3] {
    let x = target_position(instrument, shared, target, pose);
    let f = Instrument::FRAME;
    let zero = lift::<T>(0.0);
    let (origin, angles) = if instrument.spatial {
        (
            [shared[f], shared[f + 1], shared[f + 2]],
            [shared[f + 3], shared[f + 4], shared[f + 5]],
        )
    } else {
        (
            [shared[f], shared[f + 1], zero],
            [zero, zero, shared[f + 2]],
        )
    };
    let frame = [
        origin[0], origin[1], origin[2], angles[0], angles[1], angles[2],
    ];
    let inverse = crate::kinematics::chain::platform_transform(&frame).inverse();
    let local = inverse.transform_point(&nalgebra::Point3::new(x[0], x[1], x[2]));
    [local.x, local.y, local.z]
}

/// The platform pose `[x, y, z, roll, pitch, yaw]` from one row's target coordinates
/// `observed` (measurement-row order) at shared parameters `shared`; the coordinates the
/// instrument does not give (z, roll, pitch of a planar model, and the orientation of a platform
/// that does not rotate) stay at their `home` value. The fitted yaw (and roll) is taken on the
/// turn nearest the home one.
pub fn platform_pose<T: Scalar>(
    instrument: &Instrument,
    shared: &[T],
    observed: &[f64],
    home: &[f64; 6],
) -> [T; 6] {
    let observed: Vec<T> = observed.iter().map(|&v| lift::<T>(v)).collect();
    platform_pose_from(instrument, shared, &observed, home)
}

/// As [`platform_pose`], with the target coordinates in the scalar type too (for the
/// derivatives with respect to them: how the instrument's noise reaches the pose).
pub fn platform_pose_from<T: Scalar>(
    instrument: &Instrument,
    shared: &[T],
    observed: &[T],
    home: &[f64; 6],
) -> [T; 6] {
    if instrument.spatial {
        return spatial::platform_pose(instrument, shared, observed, home);
    }
    let (fx, fy, theta) = (
        shared[Instrument::FRAME],
        shared[Instrument::FRAME + 1],
        shared[Instrument::FRAME + 2],
    );
    let (s, c) = (theta.sin(), theta.cos());
    let zero = lift::<T>(0.0);
    // Each target's position in the base frame, its offset, and its orientation if measured.
    let mut points = Vec::with_capacity(instrument.targets.len());
    let (mut sin_sum, mut cos_sum, mut poses) = (zero, zero, 0usize);
    let mut at = 0;
    for (k, target) in instrument.targets.iter().enumerate() {
        let (mx, my) = (observed[at], observed[at + 1]);
        let q = [fx + c * mx - s * my, fy + s * mx + c * my];
        let o = instrument.offset_index(k);
        points.push((q, [shared[o], shared[o + 1]]));
        if target.measures == Measures::Pose {
            let yaw = theta + observed[at + 2];
            sin_sum += yaw.sin();
            cos_sum += yaw.cos();
            poses += 1;
        }
        at += target.coordinates().len();
    }
    let count = lift::<T>(points.len() as f64);
    let yaw = if !instrument.rotates {
        lift::<T>(home[5])
    } else {
        let raw = if poses > 0 {
            sin_sum.atan2(cos_sum)
        } else {
            let mean = |i: usize, j: usize| {
                points
                    .iter()
                    .fold(zero, |acc, p| acc + if j == 0 { p.0[i] } else { p.1[i] })
                    / count
            };
            let (qx, qy, tx, ty) = (mean(0, 0), mean(1, 0), mean(0, 1), mean(1, 1));
            let (mut cross, mut dot) = (zero, zero);
            for (q, t) in &points {
                let (ax, ay) = (t[0] - tx, t[1] - ty);
                let (bx, by) = (q[0] - qx, q[1] - qy);
                cross += ax * by - ay * bx;
                dot += ax * bx + ay * by;
            }
            cross.atan2(dot)
        };
        let turns = ((raw.re() - home[5]) / std::f64::consts::TAU).round();
        raw - lift::<T>(turns * std::f64::consts::TAU)
    };
    let (ps, pc) = (yaw.sin(), yaw.cos());
    let (mut px, mut py) = (zero, zero);
    for (q, t) in &points {
        px += q[0] - (pc * t[0] - ps * t[1]);
        py += q[1] - (ps * t[0] + pc * t[1]);
    }
    [
        px / count,
        py / count,
        lift::<T>(home[2]),
        lift::<T>(home[3]),
        lift::<T>(home[4]),
        yaw,
    ]
}

#[cfg(test)]
mod tests;
