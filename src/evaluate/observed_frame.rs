//! The accuracy map of a model seen through the forward kinematics, in the frame its
//! observations define (docs/models.md §10).
//!
//! A bed probe reports a height: it cannot see where the printer stands in x and y nor how it
//! is turned about the bed's normal, so no calibration from it can put the nozzle there, and
//! the raw position error of the base frame mixes those invisible motions with the real error.
//! Here the error of one target (the instrument's first: the nozzle, the reflector) is taken in
//! the instrument frame — where the calibrated model puts it, in its own identified frame,
//! against where the real mechanism takes it, in the real frame — after the best least-squares
//! motion of the instrument frame along its held components that the target's reported
//! coordinates cannot see (for a height: `frame_x`, `frame_y`, `frame_yaw`). What the
//! observations can see (a height above the bed, a common scale) is not aligned away.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;
use serde::Serialize;

use super::error_stats::ErrorStats;
use crate::measure::targets::{observe_in, target_in_frame};
use crate::model::instrument::Instrument;

/// A held frame component whose motion changes none of the reported coordinates by more than
/// this fraction of what it moves the target (at the nominal frame).
const UNSEEN: f64 = 1e-9;

/// The error of the instrument's first target in the frame the observations define.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservedFrameError {
    /// The target whose position error it is.
    pub target: String,
    /// The instrument frame's held components aligned away (their motion is invisible to what
    /// the target reports).
    pub aligned: Vec<String>,
    /// Position errors over the points both maps reach (m).
    #[serde(rename = "position_error_m")]
    pub position_error: ErrorStats,
}

/// The held frame components whose motion the first target's reported coordinates cannot see
/// at the nominal frame and the poses `poses`.
pub(crate) fn unseen_components(instrument: &Instrument, poses: &[[f64; 6]]) -> Vec<usize> {
    let nominal = instrument.nominal();
    let reported = instrument.targets[0].coordinates().len();
    (0..instrument.frame_components().len())
        .filter(|&k| !instrument.parameters[k].identified)
        .filter(|&k| {
            poses.iter().all(|pose| {
                let mut shared: Vec<Dual64> = nominal.iter().map(|&v| Dual64::from(v)).collect();
                shared[k] = shared[k].derivative();
                let pose = pose.map(Dual64::from);
                let seen = observe_in(instrument, &shared, &pose);
                let moved = target_in_frame(instrument, &shared, 0, &pose);
                let motion = moved.iter().map(|v| v.eps.abs()).fold(0.0, f64::max);
                seen[..reported]
                    .iter()
                    .all(|v| v.eps.abs() <= UNSEEN * motion)
            })
        })
        .collect()
}

/// How the first target moves in the nominal frame when each unseen frame component moves, at
/// every pose of `poses`: `3 × poses` rows (x, y, z of each pose), one column per component.
pub(crate) fn unseen_motions(
    instrument: &Instrument,
    unseen: &[usize],
    poses: &[[f64; 6]],
) -> DMatrix<f64> {
    let nominal: Vec<Dual64> = instrument
        .nominal()
        .iter()
        .map(|&v| Dual64::from(v))
        .collect();
    let mut motions = DMatrix::zeros(3 * poses.len(), unseen.len());
    for (j, &k) in unseen.iter().enumerate() {
        let mut shared = nominal.clone();
        shared[k] = shared[k].derivative();
        for (i, pose) in poses.iter().enumerate() {
            let moved = target_in_frame(instrument, &shared, 0, &pose.map(Dual64::from));
            for c in 0..3 {
                motions[(3 * i + c, j)] = moved[c].eps;
            }
        }
    }
    motions
}

/// The first target's error in the frame the observations define over the grid `targets`
/// (base-frame poses the model commands) and the poses the real mechanism `reached` there:
/// commanded in the commanding model's frame (`commanding`, every shared value), reached in
/// the real one (`real`), aligned over the unseen frame components. `None` when no point is
/// reached.
pub fn observed_frame_error(
    instrument: &Instrument,
    (commanding, real): (&[f64], &[f64]),
    targets: &[[f64; 6]],
    reached: &[Option<[f64; 6]>],
) -> Option<ObservedFrameError> {
    let pairs: Vec<([f64; 6], [f64; 6])> = targets
        .iter()
        .zip(reached)
        .filter_map(|(t, r)| r.map(|r| (*t, r)))
        .collect();
    if pairs.is_empty() {
        return None;
    }
    let commanded_poses: Vec<[f64; 6]> = pairs.iter().map(|p| p.0).collect();
    let unseen = unseen_components(instrument, &commanded_poses);
    let mut error = DVector::zeros(3 * pairs.len());
    for (i, (target, reached)) in pairs.iter().enumerate() {
        let commanded = target_in_frame(instrument, commanding, 0, target);
        let seen = target_in_frame(instrument, real, 0, reached);
        for c in 0..3 {
            error[3 * i + c] = seen[c] - commanded[c];
        }
    }
    let motions = unseen_motions(instrument, &unseen, &commanded_poses);
    if !unseen.is_empty() {
        let fit = motions.clone().svd(true, true).solve(&error, 1e-12).ok()?;
        error -= motions * fit;
    }
    let errors: Vec<f64> = (0..pairs.len())
        .map(|i| error.rows(3 * i, 3).norm())
        .collect();
    Some(ObservedFrameError {
        target: instrument.targets[0].name.clone(),
        aligned: unseen
            .iter()
            .map(|&k| instrument.parameters[k].name.clone())
            .collect(),
        position_error: ErrorStats::of(&errors)?,
    })
}
