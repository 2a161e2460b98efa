//! Error statistics and the accuracy map.
//!
//! The accuracy map is the paper's before/after picture: over a grid of the usable region, a
//! model commands each target pose (each leg's reading from the model's inverse kinematics), the
//! *real* mechanism moves there (forward kinematics with the real parameters, home assembly mode)
//! and the distance between the reached and the target pose is recorded.
use nalgebra::Rotation3;
use serde::Serialize;

pub use super::error_stats::ErrorStats;
use super::observed_frame::{observed_frame_error, ObservedFrameError};
use crate::error::{Error, Result};
use crate::identify::estimate::StrategyResult;
use crate::kinematics::chain::{attachment_on, platform_transform_f64, LazyChainFrames};
use crate::kinematics::inverse::{predict_reading, reading_value, Joints, MAX_JOINTS};
use crate::kinematics::kernel::LegInverse;
use crate::kinematics::platform::{forward, Configuration, ForwardKinematics};
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;
use crate::progress::Progress;

/// One commanded pose of an accuracy map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MapPoint {
    /// Target pose `[x, y, z, roll, pitch, yaw]` (m, rad).
    pub pose: [f64; 6],
    /// Position error of the real mechanism at this target (m); `None` when not assemblable.
    #[serde(rename = "position_error_m")]
    pub position_error: Option<f64>,
    /// Orientation error (rad) where the model measures an orientation and the point assembles.
    #[serde(rename = "orientation_error_rad")]
    pub orientation_error: Option<f64>,
}

/// Pose errors over a grid of the usable region (the paper's accuracy map).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AccuracyMap {
    /// Grid spacing (m).
    pub grid_m: f64,
    /// Fraction of the workspace region covered (e.g. 0.95 of the MIW disc).
    pub scale: f64,
    /// Every grid point, assemblable or not.
    pub points: Vec<MapPoint>,
    /// Number of points that could not be reached (the model's IK or the real FK failed).
    pub non_assemblable: usize,
    /// Position errors over the assemblable points.
    #[serde(rename = "position_error_m")]
    pub position_error: ErrorStats,
    /// Orientation errors, when the model measures an orientation.
    #[serde(rename = "orientation_error_rad")]
    pub orientation_error: Option<ErrorStats>,
    /// Seen through the forward kinematics: the error of the instrument's first target in the
    /// frame the observations define.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observed_frame: Option<ObservedFrameError>,
}

/// Map points solved between two advances of the progress bar (each chunk warm-starts its
/// inverse kinematics anew).
const PROGRESS_CHUNK: usize = 4096;

/// Largest accuracy map (grid points inside the region).
pub const MAX_MAP_POINTS: usize = 2_000_000;

/// Does the mechanism measure an orientation (roll, pitch or yaw)?
pub fn measures_orientation(mechanism: &Mechanism) -> bool {
    mechanism.measured.iter().any(|&c| c >= 3)
}

/// Distance between the positions of two poses (m).
pub fn position_error(reached: &[f64; 6], target: &[f64; 6]) -> f64 {
    ((reached[0] - target[0]).powi(2)
        + (reached[1] - target[1]).powi(2)
        + (reached[2] - target[2]).powi(2))
    .sqrt()
}

/// Angle of the rotation between the orientations of two poses (rad, in [0, π]); the poses'
/// roll, pitch, yaw follow the URDF convention `R = Rz(yaw) Ry(pitch) Rx(roll)`.
pub fn orientation_error(reached: &[f64; 6], target: &[f64; 6]) -> f64 {
    let rotation = |p: &[f64; 6]| Rotation3::from_euler_angles(p[3], p[4], p[5]);
    rotation(target).angle_to(&rotation(reached))
}

/// The grid of an accuracy map: the points of a square lattice of spacing `grid_m` from the
/// lower-left corner of the region's bounding box (as the candidate grid of pose selection)
/// that lie inside the workspace region shrunk by `scale` about the centre of that box.
/// Coordinates other than x, y stay at their home values (a constant-orientation map).
///
/// # Errors
/// A spacing that is not a positive number of metres, a scale outside (0, 1], more than
/// [`MAX_MAP_POINTS`] points, a lattice over the (scaled) bounding box of more than four
/// times that many points, or no point in the region at all.
pub fn map_grid(mechanism: &Mechanism, grid_m: f64, scale: f64) -> Result<Vec<[f64; 6]>> {
    let z = mechanism.home_pose[2];
    map_slice(mechanism, grid_m, scale, (z, z))
}

/// [`map_grid`]'s lattice with the poses at height `z` and the region's depth tested at
/// `tested_z` (the preimage of `z` under the homothety, for a slice of a spatial region
/// shrunk in z too; the map's own slice tests the home height).
///
/// # Errors
/// As [`map_grid`].
pub fn map_slice(
    mechanism: &Mechanism,
    grid_m: f64,
    scale: f64,
    (z, tested_z): (f64, f64),
) -> Result<Vec<[f64; 6]>> {
    if !(grid_m.is_finite() && grid_m > 0.0) {
        return Err(Error::Invalid(format!(
            "--map: expected a positive grid spacing in metres, found {grid_m}"
        )));
    }
    if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
        return Err(Error::Invalid(format!(
            "--map-scale: expected a fraction of the workspace region in (0, 1], found {scale}"
        )));
    }
    let region = &mechanism.workspace.region;
    let (lo, hi) = region.bounds();
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let (nx, ny) = (
        ((hi[0] - lo[0]) / grid_m + 1e-9).floor(),
        ((hi[1] - lo[1]) / grid_m + 1e-9).floor(),
    );
    // Walking the lattice costs its size, whatever the region holds: a lattice far beyond
    // the limit is refused before it is walked (a region filling little of its box, a thin
    // slice of a ball, can be refused though it holds few points; the message says so).
    let lattice = (nx + 1.0) * (ny + 1.0) * scale * scale;
    if lattice > 4.0 * MAX_MAP_POINTS as f64 {
        return Err(Error::Invalid(format!(
            "--map: a spacing of {grid_m} m makes a lattice of {lattice:.0} points over the \
             region's bounding box (scaled), more than 4 × {MAX_MAP_POINTS} to walk; choose a \
             coarser grid"
        )));
    }
    let mut poses = Vec::new();
    for j in 0..=ny as u64 {
        for i in 0..=nx as u64 {
            let point = [lo[0] + i as f64 * grid_m, lo[1] + j as f64 * grid_m];
            // In the scaled region when its preimage under the homothety is in the region.
            let preimage = [
                centre[0] + (point[0] - centre[0]) / scale,
                centre[1] + (point[1] - centre[1]) / scale,
            ];
            if region.depth([preimage[0], preimage[1], tested_z]) >= -1e-12 {
                let mut pose = mechanism.home_pose;
                pose[0] = point[0];
                pose[1] = point[1];
                pose[2] = z;
                poses.push(pose);
                if poses.len() > MAX_MAP_POINTS {
                    return Err(too_many(grid_m));
                }
            }
        }
    }
    if poses.is_empty() {
        return Err(Error::Invalid(format!(
            "--map: a spacing of {grid_m} m puts no grid point in the workspace region (scaled \
             by {scale}); choose a finer grid"
        )));
    }
    Ok(poses)
}

fn too_many(grid_m: f64) -> Error {
    Error::Invalid(format!(
        "--map: a spacing of {grid_m} m gives more than {MAX_MAP_POINTS} points; choose a coarser grid"
    ))
}

/// The pose the real mechanism reaches when `commanding` (a model's parameters, one vector per
/// leg) commands `target`: each leg's reading from the model's IK, then forward kinematics with
/// the `real` parameters, in the home assembly mode. `None` if either step fails. For many
/// targets, [`reached_poses`] does the same work once.
pub fn reached_pose(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    real: &[Vec<f64>],
    target: &[f64; 6],
) -> Option<[f64; 6]> {
    let readings: Vec<f64> = mechanism
        .legs
        .iter()
        .zip(commanding)
        .map(|(leg, phi)| predict_reading(leg, phi, target, &mechanism.home_pose).ok())
        .collect::<Option<_>>()?;
    forward(mechanism, real, &readings).ok()
}

/// [`reached_pose`] at every target of `targets`, with the real mechanism's forward kinematics
/// prepared once (`real`, [`ForwardKinematics::new`] with the real parameters).
///
/// The same poses as [`reached_pose`] to round-off, cheaper: each leg's inverse kinematics is
/// warm-started from its solution at the nearest earlier target along the list (a grid's
/// previous point, or the previous row's first point), with the branch check and the
/// from-home fallback of [`solve_warm`]; the forward kinematics starts from the target pose
/// with the commanding model's joints there, and is accepted in the home assembly mode (else
/// it is solved from home with the continuation of [`forward`]).
pub fn reached_poses(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    real: &ForwardKinematics<'_>,
    targets: &[[f64; 6]],
) -> Vec<Option<[f64; 6]>> {
    reached_poses_from(mechanism, commanding, real, targets, &mut Vec::new())
}

/// [`reached_poses`], warm-starting each leg's inverse kinematics at each target from
/// `joints`: the commanding joints of an earlier map over the same targets (target after
/// target, leg after leg; `None` where unknown), which then holds this map's. A commanding
/// model close to the earlier one (an identified model after another) makes each warm start
/// a step or two. An empty or mis-sized `joints` starts from the grid neighbours as
/// [`reached_poses`].
pub fn reached_poses_from(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    real: &ForwardKinematics<'_>,
    targets: &[[f64; 6]],
    joints: &mut Vec<Option<Joints>>,
) -> Vec<Option<[f64; 6]>> {
    commanded(mechanism, commanding, targets, joints)
        .into_iter()
        .map(|command| {
            let (readings, start) = command?;
            real.solve_near_pose(&readings, &start).ok()
        })
        .collect()
}

/// What the model of parameters `commanding` commands at each target of `targets`: every
/// leg's reading there and the configuration it reaches (the target pose with every leg's
/// joints); `None` where a leg cannot reach the target. Each leg's inverse kinematics is
/// warm-started from `joints` as in [`reached_poses_from`] (which then holds this call's).
pub fn commanded(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    targets: &[[f64; 6]],
    joints: &mut Vec<Option<Joints>>,
) -> Vec<Option<(Vec<f64>, Configuration)>> {
    let mut all = Vec::with_capacity(targets.len());
    commanded_each(mechanism, commanding, targets, joints, |_, command| {
        all.push(
            command.map(|(readings, configuration)| (readings.to_vec(), configuration.clone())),
        );
    });
    all
}

/// [`commanded`] handed to `each` target by target (its index, then its readings and
/// configuration, or `None`) in one reused buffer: the same numbers without a vector a target
/// (an accuracy map's hundreds of points, in every Monte Carlo trial).
pub fn commanded_each(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    targets: &[[f64; 6]],
    joints: &mut Vec<Option<Joints>>,
    mut each: impl FnMut(usize, Option<(&[f64], &Configuration)>),
) {
    let home = &mechanism.home_pose;
    let geometries: Vec<LegGeometry<f64>> = mechanism
        .legs
        .iter()
        .zip(commanding)
        .map(|(leg, phi)| leg.geometry(phi))
        .collect();
    let frames: Vec<LazyChainFrames> = geometries.iter().map(|_| LazyChainFrames::new()).collect();
    // Each leg's closed-form kernel where its chain has one (the generic chain otherwise).
    let inverses: Vec<LegInverse<'_>> = mechanism
        .legs
        .iter()
        .zip(geometries.iter().zip(&frames))
        .map(|(leg, (geometry, frames))| LegInverse::new(leg, geometry, frames))
        .collect();
    let legs = mechanism.legs.len();
    if joints.len() != targets.len() * legs {
        *joints = vec![None; targets.len() * legs];
    }
    // Every target's joints, leg after leg (`None` where a leg could not reach it).
    let solutions = joints;
    let seeds = warm_start_order(targets);
    let mut readings = vec![0.0; legs];
    let mut configuration = Configuration {
        pose: [0.0; 6],
        joints: vec![[0.0; MAX_JOINTS]; legs],
    };
    'targets: for (i, (target, seed)) in targets.iter().zip(seeds).enumerate() {
        let platform = platform_transform_f64(target);
        configuration.pose = *target;
        for (l, leg) in mechanism.legs.iter().enumerate() {
            let attachment = attachment_on(&platform, &geometries[l].attachment);
            let warm = solutions[i * legs + l]
                .as_ref()
                .or_else(|| seed.and_then(|s| solutions[s * legs + l].as_ref()));
            // Through a kernel, the actuated joint alone (the reading's): the passive
            // joints keep their warm starts' values, the forward step's start.
            if let Some(actuated) = inverses[l].actuated(&attachment, warm) {
                let home_joints = || crate::kinematics::inverse::joints(&leg.home_joints);
                let mut q = warm.copied().unwrap_or_else(home_joints);
                q[leg.actuated] = actuated;
                let geometry = &geometries[l];
                readings[l] = (actuated - geometry.offset) / geometry.gain;
                configuration.joints[l] = q;
                solutions[i * legs + l] = Some(q);
                continue;
            }
            let solution = inverses[l].solve_warm((target, &attachment), home, warm);
            match solution {
                Ok(solution) => {
                    readings[l] = reading_value(leg, &geometries[l], &solution);
                    configuration.joints[l] = solution.q;
                    solutions[i * legs + l] = Some(solution.q);
                }
                Err(_) => {
                    solutions[i * legs + l] = None;
                    each(i, None);
                    continue 'targets;
                }
            }
        }
        each(i, Some((&readings, &configuration)));
    }
}

/// For each target, the earlier target whose joints seed its inverse kinematics: the previous
/// one when it is about as close as the first two are to each other (a grid's spacing), else
/// the first target of the previous run of close targets (a grid's previous row), if any.
fn warm_start_order(targets: &[[f64; 6]]) -> Vec<Option<usize>> {
    let distance = |a: &[f64; 6], b: &[f64; 6]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    let spacing = match targets {
        [a, b, ..] => distance(a, b),
        _ => 0.0,
    };
    let mut run_start = 0;
    let mut previous_run_start = None;
    (0..targets.len())
        .map(|i| {
            if i == 0 {
                return None;
            }
            if distance(&targets[i], &targets[i - 1]) <= 1.5 * spacing {
                Some(i - 1)
            } else {
                previous_run_start = Some(run_start);
                run_start = i;
                previous_run_start
            }
        })
        .collect()
}

/// The accuracy map of `commanding` against the `real` mechanism over [`map_grid`]`(grid_m,
/// scale)`, with a progress bar labelled `label` on a terminal.
///
/// # Errors
/// As [`map_grid`], or no grid point that the real mechanism reaches.
pub fn accuracy_map(
    mechanism: &Mechanism,
    commanding: &[Vec<f64>],
    real: &[Vec<f64>],
    grid_m: f64,
    scale: f64,
    label: &str,
) -> Result<AccuracyMap> {
    accuracy_map_seen(
        mechanism,
        (commanding, None),
        (real, None),
        (grid_m, scale),
        label,
    )
}

/// [`accuracy_map`], and for a model seen through the forward kinematics with the commanding
/// and real instrument values (every shared parameter), the error in the frame the
/// observations define ([`observed_frame_error`]).
///
/// # Errors
/// As [`accuracy_map`].
pub fn accuracy_map_seen(
    mechanism: &Mechanism,
    (commanding, commanding_shared): (&[Vec<f64>], Option<&[f64]>),
    (real, real_shared): (&[Vec<f64>], Option<&[f64]>),
    (grid_m, scale): (f64, f64),
    label: &str,
) -> Result<AccuracyMap> {
    let grid = map_grid(mechanism, grid_m, scale)?;
    let orientation = measures_orientation(mechanism);
    let progress = Progress::new(grid.len() as u64, label);
    let real = ForwardKinematics::new(mechanism, real);
    let reached: Vec<Option<[f64; 6]>> = grid
        .chunks(PROGRESS_CHUNK)
        .flat_map(|chunk| {
            let reached = reached_poses(mechanism, commanding, &real, chunk);
            progress.advance(chunk.len() as u64);
            reached
        })
        .collect();
    let forward = mechanism.forward_instrument();
    let observed_frame = match (forward, commanding_shared, real_shared) {
        (Some(instrument), Some(commanding), Some(real)) => {
            observed_frame_error(instrument, (commanding, real), &grid, &reached)
        }
        _ => None,
    };
    let points: Vec<MapPoint> = grid
        .iter()
        .zip(reached)
        .map(|(target, reached)| MapPoint {
            pose: *target,
            position_error: reached.map(|p| position_error(&p, target)),
            orientation_error: reached
                .filter(|_| orientation)
                .map(|p| orientation_error(&p, target)),
        })
        .collect();
    let errors = |pick: fn(&MapPoint) -> Option<f64>| -> Vec<f64> {
        points.iter().filter_map(pick).collect()
    };
    let position_error = ErrorStats::of(&errors(|p| p.position_error)).ok_or_else(|| {
        Error::Invalid(format!(
            "accuracy map ({label}): the real mechanism reaches none of the {} grid points",
            points.len()
        ))
    })?;
    Ok(AccuracyMap {
        grid_m,
        scale,
        non_assemblable: points.iter().filter(|p| p.position_error.is_none()).count(),
        orientation_error: ErrorStats::of(&errors(|p| p.orientation_error)),
        position_error,
        points,
        observed_frame,
    })
}

/// The parameters a result identified, one full vector per leg of the mechanism (nominal values
/// for the legs it did not identify).
pub fn result_parameters(mechanism: &Mechanism, result: &StrategyResult) -> Vec<Vec<f64>> {
    mechanism
        .legs
        .iter()
        .map(|leg| match result.legs.iter().find(|e| e.leg == leg.name) {
            Some(estimate) => estimate.parameters.iter().map(|p| p.estimate).collect(),
            None => leg.nominal(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn a_single_error_is_its_own_rms_median_percentile_and_maximum() {
        let stats = ErrorStats::of(&[0.003]).unwrap();
        for value in [stats.rms, stats.median, stats.p95, stats.max] {
            assert!((value - 0.003).abs() < 1e-17, "{stats:?}");
        }
    }

    #[test]
    fn the_position_error_is_the_distance_between_the_positions_alone() {
        // Offsets of 3, 4 and 12 m: 13 m, whatever the orientations.
        let reached = [4.0, 6.0, 15.0, 0.5, -0.2, 1.0];
        let target = [1.0, 2.0, 3.0, 0.0, 0.3, -2.0];
        assert!((position_error(&reached, &target) - 13.0).abs() < 1e-12);
        assert!((position_error(&target, &reached) - 13.0).abs() < 1e-12);
    }

    /// `Rz(yaw) Ry(pitch) Rx(roll)` of a pose `[.., roll, pitch, yaw]`, written out.
    fn rotation(p: &[f64; 6]) -> [[f64; 3]; 3] {
        let (sr, cr) = p[3].sin_cos();
        let (sp, cp) = p[4].sin_cos();
        let (sy, cy) = p[5].sin_cos();
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    }

    #[test]
    fn the_orientation_error_is_the_angle_of_the_relative_rotation() {
        let pose = |roll: f64, pitch: f64, yaw: f64| [0.1, 0.2, 0.3, roll, pitch, yaw];
        // About one axis: the difference of the angles, the short way round.
        let yaw = orientation_error(&pose(0.0, 0.0, 3.0), &pose(0.0, 0.0, -3.0));
        assert!((yaw - (2.0 * PI - 6.0)).abs() < 1e-12, "{yaw}");
        let roll = orientation_error(&pose(0.25, 0.0, 0.0), &pose(0.0, 0.0, 0.0));
        assert!((roll - 0.25).abs() < 1e-12, "{roll}");
        // About all three: cos θ = (tr(Raᵀ Rb) − 1) / 2 with the matrices written out.
        let (a, b) = (pose(0.3, -0.2, 0.5), pose(-0.1, 0.4, 0.2));
        let (ra, rb) = (rotation(&a), rotation(&b));
        let trace: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |k| ra[k][i] * rb[k][i]))
            .sum();
        let expected = ((trace - 1.0) / 2.0).acos();
        let angle = orientation_error(&a, &b);
        assert!(
            (angle - expected).abs() < 1e-12,
            "{angle} against {expected}"
        );
        assert!(expected > 0.5, "a sizeable rotation: {expected}");
    }

    #[test]
    fn each_target_is_warm_started_from_the_previous_one_or_the_previous_rows_first() {
        // Three rows of four targets 0.1 m apart, away from the origin, listed as a grid is.
        let targets: Vec<[f64; 6]> = (0..3)
            .flat_map(|j| {
                (0..4).map(move |i| {
                    [
                        1.0 + 0.1 * i as f64,
                        2.0 + 0.1 * j as f64,
                        0.5,
                        0.0,
                        0.0,
                        0.0,
                    ]
                })
            })
            .collect();
        let expected = [
            None,
            Some(0),
            Some(1),
            Some(2),
            Some(0),
            Some(4),
            Some(5),
            Some(6),
            Some(4),
            Some(8),
            Some(9),
            Some(10),
        ];
        assert_eq!(warm_start_order(&targets), expected);
        assert_eq!(warm_start_order(&targets[..1]), [None]);
        assert_eq!(warm_start_order(&[]), []);
    }
}
