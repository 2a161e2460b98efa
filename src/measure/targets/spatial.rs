//! The spatial instrument: what it reports of a platform pose, and the pose fitted back from
//! its report (see [`super`] for the planar one and the conventions).
//!
//! The frame `F = (f, R_f)` with `R_f = Rz(yaw) Ry(pitch) Rx(roll)` of its angles (the platform
//! pose's convention); the platform `P = (p, R_P)`. Target `k` at offset `t_k` is reported at
//! `m_k = R_fᵀ (p + R_P t_k − f)`; a pose target adds the roll, pitch, yaw of `R_fᵀ R_P` (its axes
//! are the platform's). Back, every target's base-frame position is `q_k = f + R_f m_k`; the
//! platform's rotation is the chordal mean of the pose targets' `R_f R(m_k's angles)` if there
//! are any, else the least-squares rotation of the centred offsets onto the centred positions
//! (both by [`nearest_rotation`]); a platform that does not rotate keeps its home orientation.
//! Then `p = mean_k (q_k − R_P t_k)`.

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::horn::nearest_rotation;
use crate::model::instrument::{Instrument, Measures};
use crate::scalar::{lift, Scalar};

/// `Rz(yaw) Ry(pitch) Rx(roll)` of `angles = [roll, pitch, yaw]`.
fn rotation<T: Scalar>(roll: T, pitch: T, yaw: T) -> Matrix3<T> {
    Rotation3::from_euler_angles(roll, pitch, yaw).into_inner()
}

/// `[roll, pitch, yaw]` of `r = Rz(yaw) Ry(pitch) Rx(roll)`, with `|pitch| ≤ π/2`.
pub(crate) fn angles<T: Scalar>(r: &Matrix3<T>) -> [T; 3] {
    let roll = r[(2, 1)].atan2(r[(2, 2)]);
    let pitch = (-r[(2, 0)]).atan2((r[(0, 0)] * r[(0, 0)] + r[(1, 0)] * r[(1, 0)]).sqrt());
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    [roll, pitch, yaw]
}

fn vector<T: Scalar>(values: &[T]) -> Vector3<T> {
    Vector3::new(values[0], values[1], values[2])
}

/// The instrument frame's origin `f` and its rotation transposed, `R_fᵀ`, from the shared
/// parameters: the part of [`observe`] that is the same at every pose (computed once for many
/// rows).
#[derive(Debug, Clone, Copy)]
pub struct Frame<T: Scalar> {
    origin: Vector3<T>,
    transposed: Matrix3<T>,
}

impl<T: Scalar> Frame<T> {
    /// The frame at the shared parameters `shared`.
    pub fn new(shared: &[T]) -> Self {
        let frame = rotation(
            shared[Instrument::FRAME + 3],
            shared[Instrument::FRAME + 4],
            shared[Instrument::FRAME + 5],
        );
        Self {
            origin: vector(&shared[Instrument::FRAME..]),
            transposed: frame.transpose(),
        }
    }

    /// The frame's origin `f` in the base frame.
    pub fn origin(&self) -> &Vector3<T> {
        &self.origin
    }

    /// The frame's rotation transposed, `R_fᵀ`.
    pub fn transposed(&self) -> &Matrix3<T> {
        &self.transposed
    }
}

/// The platform's rotation `R_P` at `pose` (its roll, pitch, yaw).
pub fn platform_rotation<T: Scalar>(pose: &[T; 6]) -> Matrix3<T> {
    rotation(pose[3], pose[4], pose[5])
}

/// The instrument's report of every target at `pose` (see [`super::observe_in`]).
pub(super) fn observe<T: Scalar>(instrument: &Instrument, shared: &[T], pose: &[T; 6]) -> Vec<T> {
    let mut observed = Vec::with_capacity(instrument.observed_len());
    let platform = platform_rotation(pose);
    observe_framed(
        instrument,
        (shared, &Frame::new(shared)),
        (&platform, pose),
        &mut observed,
    );
    observed
}

/// [`observe`] with the frame `frame` of the shared parameters `shared` and the platform's
/// rotation `platform` at `pose` computed beforehand, the report appended to `observed`: the
/// same numbers, bit for bit.
pub fn observe_framed<T: Scalar>(
    instrument: &Instrument,
    (shared, frame): (&[T], &Frame<T>),
    (platform, pose): (&Matrix3<T>, &[T; 6]),
    observed: &mut Vec<T>,
) {
    let p = vector(&pose[..]);
    // A platform that does not turn (the identity, differentiated by nothing) leaves every
    // offset as it is: `R_P t = t`, the product's own numbers.
    let turns = platform.iter().enumerate().any(|(k, v)| {
        let bits = v.re().to_bits();
        // 1 on the diagonal, ±0 elsewhere
        let identity = match k % 4 {
            0 => bits == 1f64.to_bits(),
            _ => bits & !(1 << 63) == 0,
        };
        !identity || !v.is_constant()
    });
    for (k, target) in instrument.targets.iter().enumerate() {
        let t = vector(&shared[instrument.offset_index(k)..]);
        let turned = if turns { platform * t } else { t };
        let v = p + turned - frame.origin;
        match target.measures {
            // Only the reported coordinates of `R_fᵀ v`, each summed as the product sums it.
            Measures::Coordinates(_) => observed.extend(
                target
                    .pose_indices()
                    .iter()
                    .map(|&c| row_times(&frame.transposed, c, &v)),
            ),
            _ => observed.extend((frame.transposed * v).iter()),
        }
        if target.measures == Measures::Pose {
            observed.extend(angles(&(frame.transposed * platform)));
        }
    }
}

/// Row `row` of `m` times `v`: the entry `row` of `m * v`, summed in the order nalgebra's
/// product sums it (column after column).
fn row_times<T: Scalar>(m: &Matrix3<T>, row: usize, v: &Vector3<T>) -> T {
    m[(row, 0)] * v[0] + m[(row, 1)] * v[1] + m[(row, 2)] * v[2]
}

/// The platform pose from one row's target coordinates (see [`super::platform_pose_from`]).
pub(super) fn platform_pose<T: Scalar>(
    instrument: &Instrument,
    shared: &[T],
    observed: &[T],
    home: &[f64; 6],
) -> [T; 6] {
    let f = vector(&shared[Instrument::FRAME..]);
    let frame = rotation(
        shared[Instrument::FRAME + 3],
        shared[Instrument::FRAME + 4],
        shared[Instrument::FRAME + 5],
    );
    // Each target's position in the base frame and its offset; the pose targets' rotations.
    let mut points = Vec::with_capacity(instrument.targets.len());
    let mut rotations = Matrix3::<T>::zeros();
    let mut poses = 0usize;
    let mut at = 0;
    for (k, target) in instrument.targets.iter().enumerate() {
        let q = f + frame * vector(&observed[at..]);
        points.push((q, vector(&shared[instrument.offset_index(k)..])));
        if target.measures == Measures::Pose {
            rotations += frame * rotation(observed[at + 3], observed[at + 4], observed[at + 5]);
            poses += 1;
        }
        at += target.coordinates().len();
    }
    let count = lift::<T>(points.len() as f64);
    let (platform, orientation) = if !instrument.rotates {
        let [roll, pitch, yaw] = [home[3], home[4], home[5]].map(lift::<T>);
        (rotation(roll, pitch, yaw), [roll, pitch, yaw])
    } else {
        let r = if poses > 0 {
            nearest_rotation(&rotations)
        } else {
            let q_mean = points.iter().fold(Vector3::zeros(), |acc, p| acc + p.0) / count;
            let t_mean = points.iter().fold(Vector3::zeros(), |acc, p| acc + p.1) / count;
            let m = points.iter().fold(Matrix3::zeros(), |acc, (q, t)| {
                acc + (q - q_mean) * (t - t_mean).transpose()
            });
            nearest_rotation(&m)
        };
        let [roll, pitch, yaw] = angles(&r);
        // Roll and yaw on the turn nearest home (pitch is within ±π/2).
        let near = |angle: T, home: f64| {
            let turns = ((angle.re() - home) / std::f64::consts::TAU).round();
            angle - lift::<T>(turns * std::f64::consts::TAU)
        };
        (r, [near(roll, home[3]), pitch, near(yaw, home[5])])
    };
    let p = points
        .iter()
        .fold(Vector3::zeros(), |acc, (q, t)| acc + q - platform * t)
        / count;
    [
        p[0],
        p[1],
        p[2],
        orientation[0],
        orientation[1],
        orientation[2],
    ]
}

#[cfg(test)]
mod tests;
