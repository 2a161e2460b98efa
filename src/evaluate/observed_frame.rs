//! The accuracy map of a model seen through the forward kinematics, in the frame its
//! observations define (docs/models.md §10).
//!
//! A bed probe reports a height: it cannot see where the printer stands along the bed nor how
//! it is turned about the bed's normal, so no calibration from it can put the nozzle there, and
//! the raw position error of the base frame mixes those invisible motions with the real error.
//! Here the error of one target (the instrument's first: the nozzle, the reflector) is taken in
//! the instrument frame — where the calibrated model puts it, in its own identified frame,
//! against where the real mechanism takes it, in the real frame — after the best least-squares
//! motion of the instrument frame that the target's reported coordinates cannot see.
//!
//! **The unseen motions.** A small motion of the instrument frame in its own axes, the twist
//! `δ = (v, ω)` (`F' = F · exp(δ)`), moves a target at `m` in the frame to
//! `m' = m − v − ω × m`: `∂m/∂v = −I`, `∂m/∂ω = [m]×` (planar: `v = (v_x, v_y)`, `ω` about
//! `z`). The target's reported coordinates are some of `m` (and, for a pose target, its
//! orientation, which `ω` turns), so the twists they cannot see are the null space of those
//! rows stacked over the poses, each twist component first scaled by how far it moves the
//! target. Taken in the frame's own axes the answer does not depend on where the frame sits
//! nor how it is tilted: for a height (the frame's `z`) it is the motion along the frame's
//! `x`, `y` and the turn about its `z`, whatever the bed's tilt and turn. What the
//! observations can see (a height above the bed, a common scale) is not aligned away.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::error_stats::ErrorStats;
use crate::measure::targets::target_in_frame;
use crate::model::instrument::Instrument;

/// A twist whose (scaled) change of the reported coordinates is at most this fraction of how
/// far it moves the target is unseen: round-off, not a tilt (a bed tilted by 1e-10 rad sees
/// motion along the base frame's x by 1e-10 of it; along its own x by nothing).
const UNSEEN: f64 = 1e-9;

/// The error of the instrument's first target in the frame the observations define.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObservedFrameError {
    /// The target whose position error it is.
    pub target: String,
    /// The instrument frame's motions aligned away, in its own axes (`along x`, `about z`, …;
    /// a combination is described as `N other motion(s)`): the target's reported coordinates
    /// cannot see them.
    pub aligned: Vec<String>,
    /// Position errors over the points both maps reach (m).
    #[serde(rename = "position_error_m")]
    pub position_error: ErrorStats,
}

/// The instrument frame's motions that its first target's reported coordinates cannot see at
/// a set of poses: a basis of twists in the frame's own axes and how they move the target.
#[derive(Debug, Clone, PartialEq)]
pub struct UnseenFrame {
    /// The unseen twists (columns; rows the twist's components: `v_x, v_y, ω` planar,
    /// `v_x, v_y, v_z, ω_x, ω_y, ω_z` spatial), orthonormal after scaling.
    pub twists: DMatrix<f64>,
    /// The target's motion in the frame under each unseen twist: `3 × poses` rows (x, y, z of
    /// each pose), one column per twist.
    pub motions: DMatrix<f64>,
    /// The twists named: the frame's own axes they move along or about, or a count of other
    /// motions when the unseen space is not spanned by axes.
    pub names: Vec<String>,
}

impl UnseenFrame {
    /// No unseen motion.
    pub fn is_empty(&self) -> bool {
        self.twists.ncols() == 0
    }

    /// Takes out of each column of `values` (3 rows per pose, as [`Self::motions`]) its
    /// least-squares fit by the unseen motions: what is left is what the observations see.
    /// By an orthonormal basis of the motions (their thin QR: they are independent, the
    /// twists orthonormal after scaling), `values − Q Qᵀ values`.
    pub fn project_out<C: nalgebra::Dim, S>(
        &self,
        values: &mut nalgebra::Matrix<f64, nalgebra::Dyn, C, S>,
    ) where
        S: nalgebra::StorageMut<f64, nalgebra::Dyn, C>,
    {
        if self.is_empty() {
            return;
        }
        let q = self.motions.clone().qr().q();
        let along = q.tr_mul(values);
        *values -= q * along;
    }
}

/// The names of the twist components, in [`UnseenFrame::twists`]' row order.
const PLANAR_TWIST: [&str; 3] = ["along x", "along y", "about z"];
const SPATIAL_TWIST: [&str; 6] = [
    "along x", "along y", "along z", "about x", "about y", "about z",
];

/// How the first target moves in the frame (3 rows: x, y, z) and how its reported coordinates
/// change (one row each), under each twist component, at frame-local position `m`.
fn twist_rows(instrument: &Instrument, m: [f64; 3]) -> (DMatrix<f64>, DMatrix<f64>) {
    let target = &instrument.targets[0];
    let moved = if instrument.spatial {
        // [−I | [m]×]
        DMatrix::from_row_slice(
            3,
            6,
            &[
                -1.0, 0.0, 0.0, 0.0, -m[2], m[1], //
                0.0, -1.0, 0.0, m[2], 0.0, -m[0], //
                0.0, 0.0, -1.0, -m[1], m[0], 0.0,
            ],
        )
    } else {
        // m' = m − v − ω ẑ × m, ẑ × m = (−m_y, m_x, 0).
        DMatrix::from_row_slice(3, 3, &[-1.0, 0.0, m[1], 0.0, -1.0, -m[0], 0.0, 0.0, 0.0])
    };
    let width = moved.ncols();
    let reported = target.pose_indices();
    let seen = DMatrix::from_fn(reported.len(), width, |r, j| {
        let i = reported[r];
        if i < 3 {
            moved[(i, j)]
        } else {
            // An orientation coordinate: turned (against) by the rotation about its own axis
            // (planar: the one rotation; spatial: roll, pitch, yaw ↔ ω_x, ω_y, ω_z to first
            // order at any orientation up to an invertible map, which keeps the null space).
            let axis = if instrument.spatial { 3 + (i - 3) } else { 2 };
            if j == axis {
                -1.0
            } else {
                0.0
            }
        }
    });
    (moved, seen)
}

/// The instrument frame's motions its first target's reported coordinates cannot see at the
/// frame `shared` (every shared value, layout of [`Instrument`]) and the poses `poses`.
pub fn unseen_frame(instrument: &Instrument, shared: &[f64], poses: &[[f64; 6]]) -> UnseenFrame {
    let width = if instrument.spatial { 6 } else { 3 };
    let rows: Vec<(DMatrix<f64>, DMatrix<f64>)> = poses
        .iter()
        .map(|pose| twist_rows(instrument, target_in_frame(instrument, shared, 0, pose)))
        .collect();
    let moved = stacked(rows.iter().map(|r| &r.0), width);
    let seen = stacked(rows.iter().map(|r| &r.1), width);
    // Each twist component scaled to move the target by one (RMS over the poses); one that
    // moves it not at all (a turn about a lone target on its axis) keeps its unit size.
    let scales: Vec<f64> = moved
        .column_iter()
        .map(|c| {
            let norm = c.norm();
            if norm > 0.0 {
                norm
            } else {
                1.0
            }
        })
        .collect();
    let mut scaled = seen;
    for (j, s) in scales.iter().enumerate() {
        scaled.column_mut(j).unscale_mut(*s);
    }
    // At least square (padded with zero rows) so that the SVD gives every right singular
    // vector.
    let mut padded = DMatrix::zeros(scaled.nrows().max(width), width);
    padded.rows_mut(0, scaled.nrows()).copy_from(&scaled);
    // Every scale is positive and the poses finite: a NaN here would reach nalgebra's SVD,
    // which may never return from one.
    debug_assert!(
        padded.iter().all(|v| v.is_finite()),
        "unseen_frame: scaled motions not finite"
    );
    let svd = padded.svd(false, true);
    let v_t = svd.v_t.expect("asked for V");
    let null: Vec<DVector<f64>> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] <= UNSEEN)
        .map(|i| v_t.row(i).transpose())
        .collect();
    let names = twist_names(instrument, &null);
    let twists = DMatrix::from_fn(width, null.len(), |i, j| null[j][i] / scales[i]);
    let motions = &moved * &twists;
    UnseenFrame {
        twists,
        motions,
        names,
    }
}

/// The blocks one under the other (`width` columns).
fn stacked<'b>(
    blocks: impl Iterator<Item = &'b DMatrix<f64>> + Clone,
    width: usize,
) -> DMatrix<f64> {
    let count: usize = blocks.clone().map(|b| b.nrows()).sum();
    let mut stacked = DMatrix::zeros(count, width);
    let mut at = 0;
    for block in blocks {
        stacked.rows_mut(at, block.nrows()).copy_from(block);
        at += block.nrows();
    }
    stacked
}

/// The unseen (scaled, orthonormal) twists `null` named by the frame axes they span: each
/// axis lying in the span, and the rest counted.
fn twist_names(instrument: &Instrument, null: &[DVector<f64>]) -> Vec<String> {
    let axes: &[&str] = if instrument.spatial {
        &SPATIAL_TWIST
    } else {
        &PLANAR_TWIST
    };
    let mut names: Vec<String> = (0..axes.len())
        .filter(|&j| {
            let inside: f64 = null.iter().map(|v| v[j].powi(2)).sum();
            inside >= 1.0 - 1e-6
        })
        .map(|j| axes[j].to_string())
        .collect();
    if names.len() < null.len() {
        names.push(format!("{} other motion(s)", null.len() - names.len()));
    }
    names
}

/// The first target's error in the frame the observations define over the grid `targets`
/// (base-frame poses the model commands) and the poses the real mechanism `reached` there:
/// commanded in the commanding model's frame (`commanding`, every shared value), reached in
/// the real one (`real`), aligned over the frame motions the target's reported coordinates
/// cannot see ([`unseen_frame`], at the commanding frame). `None` when no point is reached.
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
    let unseen = unseen_frame(instrument, commanding, &commanded_poses);
    let mut error = DVector::zeros(3 * pairs.len());
    for (i, (target, reached)) in pairs.iter().enumerate() {
        let commanded = target_in_frame(instrument, commanding, 0, target);
        let seen = target_in_frame(instrument, real, 0, reached);
        for c in 0..3 {
            error[3 * i + c] = seen[c] - commanded[c];
        }
    }
    unseen.project_out(&mut error);
    let errors: Vec<f64> = (0..pairs.len())
        .map(|i| error.rows(3 * i, 3).norm())
        .collect();
    Some(ObservedFrameError {
        target: instrument.targets[0].name.clone(),
        aligned: unseen.names,
        position_error: ErrorStats::of(&errors)?,
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::{twist_rows, unseen_frame};
    use crate::model::Mechanism;

    fn bundled(name: &str) -> Mechanism {
        Mechanism::load(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("models")
                .join(name),
        )
        .unwrap()
    }

    /// A target fixed in the world seen from a frame moved by a twist in the frame's own axes:
    /// its frame-local position becomes `Rᵀ (m − v)`. Each column of the motion matrix is the
    /// central difference of that under one component (rotations built as matrices here), and
    /// each reported coordinate's row is the motion's row for a position coordinate.
    #[test]
    fn the_motions_are_the_derivatives_of_the_local_position_under_each_twist() {
        let rotation = |axis: usize, a: f64| -> [[f64; 3]; 3] {
            let (s, c) = a.sin_cos();
            match axis {
                0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
                1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
                _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
            }
        };
        // Rᵀ (m − v) for a twist component j by `e`.
        let local = |j: usize, e: f64, m: [f64; 3]| -> [f64; 3] {
            let mut shifted = m;
            if j < 3 {
                shifted[j] -= e;
                return shifted;
            }
            let r = rotation(j - 3, e);
            std::array::from_fn(|i| (0..3).map(|k| r[k][i] * m[k]).sum())
        };
        let m = [0.3, -0.2, 0.5];
        let probe = bundled("delta-probe.yaml");
        let instrument = probe.forward_instrument().unwrap();
        let (moved, seen) = twist_rows(instrument, m);
        assert_eq!(moved.shape(), (3, 6));
        let h = 1e-6;
        for j in 0..6 {
            let (up, down) = (local(j, h, m), local(j, -h, m));
            for i in 0..3 {
                let expected = (up[i] - down[i]) / (2.0 * h);
                assert!(
                    (moved[(i, j)] - expected).abs() < 1e-9,
                    "row {i}, twist {j}: {} vs {expected}",
                    moved[(i, j)]
                );
            }
            // The probe reports the height: the motion's z row.
            assert!((seen[(0, j)] - moved[(2, j)]).abs() < 1e-15);
        }
        // A target reporting its pose: its orientation turns against the frame's rotation
        // about the same axis, and moves with no translation or other rotation.
        let mut posed = instrument.clone();
        posed.targets[0].measures = crate::model::instrument::Measures::Pose;
        let (moved, seen) = twist_rows(&posed, [0.3, -0.2, 0.5]);
        assert_eq!(seen.shape(), (6, 6));
        for j in 0..6 {
            for i in 0..3 {
                assert!((seen[(i, j)] - moved[(i, j)]).abs() < 1e-15);
            }
            for a in 0..3 {
                let expected = if j == 3 + a { -1.0 } else { 0.0 };
                assert!(
                    (seen[(3 + a, j)] - expected).abs() < 1e-15,
                    "orientation {a}, twist {j}: {}",
                    seen[(3 + a, j)]
                );
            }
        }
        // Planar: (v_x, v_y, ω about z), the z row zero.
        let tracker = bundled("5r-tracker.yaml");
        let planar = tracker.instrument.as_ref().unwrap();
        let m = [0.3, -0.2, 0.0];
        let (moved, _) = twist_rows(planar, m);
        assert_eq!(moved.shape(), (3, 3));
        for (j, component) in [0, 1, 5].into_iter().enumerate() {
            let (up, down) = (local(component, h, m), local(component, -h, m));
            for i in 0..3 {
                let expected = (up[i] - down[i]) / (2.0 * h);
                assert!(
                    (moved[(i, j)] - expected).abs() < 1e-9,
                    "planar row {i}, twist {j}: {} vs {expected}",
                    moved[(i, j)]
                );
            }
        }
    }

    /// Each twist is judged by how much it changes the reported height per unit of how far it
    /// moves the target: a turn about y with the nozzle 1e-12 m and 2e-12 m from the frame's
    /// origin along x changes the heights by as much as it moves the nozzle, and is seen beside
    /// the rise along z; the four others that change no height (along x, along y, about x,
    /// which moves nothing there, and about z) are not. Unscaled, that turn's 1e-12 change
    /// would count as round-off.
    #[test]
    fn a_twist_is_seen_by_its_change_per_unit_of_motion_however_small_the_lever() {
        let probe = bundled("delta-probe.yaml");
        let instrument = probe.forward_instrument().unwrap();
        let shared = instrument.nominal();
        for lever in [1e-12, 0.1] {
            // The platform puts the nozzle (0.02 m below it) at (lever, 0, 0) and (2 lever, 0,
            // 0) on the bed: two heights that tell a rise from a turn about y.
            let poses = [1.0, 2.0].map(|k| [k * lever, 0.0, 0.02, 0.0, 0.0, 0.0]);
            let unseen = unseen_frame(instrument, &shared, &poses);
            assert_eq!(
                unseen.twists.ncols(),
                4,
                "lever {lever}: {:?}",
                unseen.names
            );
            assert_eq!(
                unseen.names,
                ["along x", "along y", "about x", "about z"],
                "lever {lever}"
            );
        }
    }
}
