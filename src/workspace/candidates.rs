//! Feasible candidate poses: a grid over the usable workspace (spacing `grid` in x, y — and z
//! for a spatial region — from the lower corner of the usable region's bounding box, each
//! ranged coordinate, e.g. an orientation angle, at `range_levels` values), kept when the pose
//! is inside the region with its margin, every leg reaches it on its home branch with its joints
//! within their URDF limits, and it clears the serial and parallel singularity thresholds.
//! Geometry and kinematics only: the selection module's `candidates` adds the identification
//! rows.

use super::limits::check_limits;
use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::chain::ChainFrames;
use crate::kinematics::inverse::{solve_from_home, LegSolution};
use crate::kinematics::singularity::ParallelMeasure;
use crate::model::Mechanism;

/// Largest candidate grid (poses before the feasibility checks).
pub const MAX_GRID_POSES: usize = 2_000_000;

/// One feasible pose.
#[derive(Debug, Clone)]
pub struct FeasiblePose {
    /// The pose `[x, y, z, roll, pitch, yaw]`.
    pub pose: [f64; 6],
    /// Per leg, its home-branch solution at the pose (nominal parameters).
    pub solutions: Vec<LegSolution>,
    /// Smallest serial (type I) measure over the legs.
    pub serial: f64,
    /// Parallel (type II) measure, when defined.
    pub parallel: Option<f64>,
}

/// The feasible poses of the grid (as [`FeasiblePose`]s, or the selection module's candidates)
/// and what was rejected.
#[derive(Debug, Clone, PartialEq)]
pub struct FeasiblePoses<P = FeasiblePose> {
    /// Feasible poses, in grid order.
    pub candidates: Vec<P>,
    /// Grid points inside the region with its margin.
    pub inside: usize,
    /// Rejected: a leg cannot reach the pose on its home branch.
    pub unreachable: usize,
    /// Rejected: a leg reaches the pose only with a joint beyond its URDF limits.
    pub beyond_limits: usize,
    /// Rejected: too close to a serial singularity.
    pub near_serial: usize,
    /// Rejected: too close to a parallel singularity.
    pub near_parallel: usize,
    /// Grid spacing used, metres.
    pub spacing: f64,
}

impl<P> FeasiblePoses<P> {
    /// The same poses and counts, each pose turned into what `f` makes of it.
    pub fn map<Q>(self, f: impl FnMut(P) -> Q) -> FeasiblePoses<Q> {
        FeasiblePoses {
            candidates: self.candidates.into_iter().map(f).collect(),
            inside: self.inside,
            unreachable: self.unreachable,
            beyond_limits: self.beyond_limits,
            near_serial: self.near_serial,
            near_parallel: self.near_parallel,
            spacing: self.spacing,
        }
    }
}

/// The feasible poses of `mechanism`'s candidate grid with spacing `spacing` (metres; default:
/// the model's `workspace.grid`), at the nominal parameters.
///
/// # Errors
/// No spacing given anywhere, a grid too fine, or no feasible pose.
pub fn feasible_poses(mechanism: &Mechanism, spacing: Option<f64>) -> Result<FeasiblePoses> {
    let workspace = &mechanism.workspace;
    let spacing = spacing.or(workspace.grid).ok_or_else(|| Error::Model {
        path: mechanism.model_path.clone(),
        field: "workspace.grid".into(),
        message: "missing: pose selection needs a candidate grid spacing (metres)".into(),
    })?;
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(Error::Invalid(format!(
            "grid spacing: expected a positive number of metres, found {spacing}"
        )));
    }
    let nominal = mechanism.nominal_parameters();
    let parallel = match ParallelMeasure::new(mechanism, nominal.clone()) {
        Ok(measure) => Some(measure),
        Err(KinematicsError::NotSquare { .. }) => None,
        Err(err) => return Err(err.into()),
    };
    let legs: Vec<_> = mechanism
        .legs
        .iter()
        .zip(&nominal)
        .map(|(leg, phi)| {
            let geometry = leg.geometry(phi);
            let frames = ChainFrames::new(&geometry);
            (leg, geometry, frames)
        })
        .collect();
    let mut feasible = FeasiblePoses {
        candidates: Vec::new(),
        inside: 0,
        unreachable: 0,
        beyond_limits: 0,
        near_serial: 0,
        near_parallel: 0,
        spacing,
    };
    let poses = grid(mechanism, spacing)?;
    let progress = crate::progress::Progress::new(poses.len() as u64, "candidate poses");
    for pose in poses {
        progress.advance(1);
        if !workspace.contains(&pose) {
            continue;
        }
        feasible.inside += 1;
        let Ok(solutions) = legs
            .iter()
            .map(|(leg, geometry, frames)| {
                solve_from_home(leg, geometry, frames, &pose, &mechanism.home_pose)
                    .map(|solution| solution.to_leg_solution(leg))
            })
            .collect::<Result<Vec<_>, _>>()
        else {
            feasible.unreachable += 1;
            continue;
        };
        let within = mechanism.legs.iter().zip(&solutions);
        if within
            .map(|(leg, solution)| check_limits(leg, &solution.q))
            .any(|checked| checked.is_err())
        {
            feasible.beyond_limits += 1;
            continue;
        }
        let serial = solutions
            .iter()
            .zip(&mechanism.legs)
            .map(|(solution, leg)| leg.home_branch_measure(solution.normalised_determinant))
            .fold(f64::INFINITY, f64::min);
        if serial < workspace.serial_threshold {
            feasible.near_serial += 1;
            continue;
        }
        let parallel = match &parallel {
            Some(measure) => Some(measure.at_solutions(&pose, &solutions)?),
            None => None,
        };
        if parallel.is_some_and(|p| p < workspace.parallel_threshold) {
            feasible.near_parallel += 1;
            continue;
        }
        feasible.candidates.push(FeasiblePose {
            pose,
            solutions,
            serial,
            parallel,
        });
    }
    if feasible.candidates.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no feasible candidate pose ({} grid points inside the usable workspace: {} unreachable, {} beyond a joint limit, {} near a serial singularity, {} near a parallel singularity)",
            mechanism.model_path.display(),
            feasible.inside,
            feasible.unreachable,
            feasible.beyond_limits,
            feasible.near_serial,
            feasible.near_parallel
        )));
    }
    Ok(feasible)
}

/// Grid poses from the lower corner of the usable region's bounding box (the region's bounds
/// moved in by the margin; in x, y for a planar region, in x, y, z for a spatial one) × ranged
/// coordinate levels.
///
/// # Errors
/// More than [`MAX_GRID_POSES`] poses (a spacing too fine for the region).
fn grid(mechanism: &Mechanism, spacing: f64) -> Result<Vec<[f64; 6]>> {
    let workspace = &mechanism.workspace;
    let (lo, hi) = workspace.region.bounds();
    let margin = workspace.margin;
    // One axis per region dimension: (pose coordinate, lowest value, number of steps).
    let mut axes = vec![(0, lo[0], hi[0]), (1, lo[1], hi[1])];
    if let Some([z_lo, z_hi]) = workspace.region.z_bounds() {
        axes.push((2, z_lo, z_hi));
    }
    let axes: Vec<(usize, f64, f64)> = axes
        .into_iter()
        .map(|(c, low, high)| {
            let (low, high) = (low + margin, high - margin);
            (c, low, ((high - low) / spacing + 1e-9).floor())
        })
        .collect();
    let ranged = workspace.ranges.iter().skip(2).flatten().count();
    let total = axes.iter().map(|a| a.2 + 1.0).product::<f64>()
        * (workspace.range_levels as f64).powi(ranged as i32);
    if total > MAX_GRID_POSES as f64 {
        return Err(Error::Invalid(format!(
            "grid spacing {spacing} m (workspace.grid or --grid) gives {total:.3e} grid poses; \
             at most {MAX_GRID_POSES} are allowed: use a larger spacing"
        )));
    }
    // The values of each gridded coordinate: the region's axes, then the ranged coordinates.
    let mut gridded: Vec<(usize, Vec<f64>)> = axes
        .iter()
        .map(|&(c, low, steps)| {
            let values = (0..=steps as usize).map(|i| low + i as f64 * spacing);
            (c, values.collect())
        })
        .collect();
    for (coordinate, range) in workspace.ranges.iter().enumerate().skip(2) {
        let Some([min, max]) = *range else { continue };
        let levels = workspace.range_levels;
        let values: Vec<f64> = if levels == 1 {
            vec![(min + max) / 2.0]
        } else {
            (0..levels)
                .map(|k| min + (max - min) * k as f64 / (levels - 1) as f64)
                .collect()
        };
        gridded.push((coordinate, values));
    }
    let mut points = vec![mechanism.home_pose];
    for (coordinate, values) in &gridded {
        points = points
            .iter()
            .flat_map(|p| {
                values.iter().map(move |&v| {
                    let mut pose = *p;
                    pose[*coordinate] = v;
                    pose
                })
            })
            .collect();
    }
    Ok(points)
}
