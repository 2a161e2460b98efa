//! Platform forward kinematics: the measured pose reached for given actuator readings, by
//! Newton's method on all legs' closure equations at once, from the home configuration, staying
//! in the home assembly mode.
//!
//! Unknowns: the measured pose coordinates and every leg's passive joints; equations: every
//! leg's closure with its actuated joint at `gain·reading + offset`.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use super::chain::{attachment_world, tip_and_jacobian};
use super::inverse::{predict_reading, wrap_angle};
use crate::error::KinematicsError;
use crate::model::joint::JointKind;
use crate::model::Mechanism;

const MAX_ITERATIONS: usize = 50;

/// The unknowns' layout and the home assembly sign.
struct Layout {
    /// Columns of the pose coordinates (indices into the 6-pose).
    pose: Vec<usize>,
    /// Per leg, the indices (into the leg's moving joints) of the passive joints.
    passive: Vec<Vec<usize>>,
}

fn layout(mechanism: &Mechanism) -> Layout {
    Layout {
        pose: mechanism.measured.clone(),
        passive: mechanism
            .legs
            .iter()
            .map(|leg| {
                (0..leg.moving.len())
                    .filter(|&i| i != leg.actuated)
                    .collect()
            })
            .collect(),
    }
}

/// Forward kinematics for readings `readings` (one per leg) with parameters `params` (one full
/// vector per leg). Readings are continued from the home readings to stay on the home assembly.
///
/// # Errors
/// [`KinematicsError::NotAssemblable`], [`KinematicsError::AssemblyModeChange`], or a
/// mechanism whose unknowns and equations do not match (reported as not assemblable).
pub fn forward(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    readings: &[f64],
) -> Result<[f64; 6], KinematicsError> {
    let layout = layout(mechanism);
    let home = mechanism.home_pose;
    let home_readings: Vec<f64> = mechanism
        .legs
        .iter()
        .zip(params)
        .map(|(leg, phi)| predict_reading(leg, phi, &home, &home))
        .collect::<Result<_, _>>()?;
    let mut pose = home;
    let mut joints = home_joints(mechanism);
    let home_sign = newton(
        mechanism,
        &layout,
        params,
        &home_readings,
        &mut pose,
        &mut joints,
    )?
    .signum();
    for steps in [1usize, 8, 32] {
        let mut trial_pose = home;
        let mut trial_joints = home_joints(mechanism);
        let mut ok = true;
        for step in 1..=steps {
            let t = step as f64 / steps as f64;
            let target: Vec<f64> = home_readings
                .iter()
                .zip(readings)
                .map(|(h, r)| h + t * (r - h))
                .collect();
            match newton(
                mechanism,
                &layout,
                params,
                &target,
                &mut trial_pose,
                &mut trial_joints,
            ) {
                Ok(sign) if sign * home_sign > 0.0 => {}
                _ => {
                    ok = false;
                    break;
                }
            }
        }
        if ok {
            return Ok(trial_pose);
        }
    }
    let mut pose = home;
    let mut joints = home_joints(mechanism);
    match newton(mechanism, &layout, params, readings, &mut pose, &mut joints) {
        Ok(_) => Err(KinematicsError::AssemblyModeChange),
        Err(err) => Err(err),
    }
}

/// Newton on the stacked closures; updates `pose` and `joints`; returns the determinant of the
/// column-normalised FK Jacobian (its sign is the assembly mode).
fn newton(
    mechanism: &Mechanism,
    layout: &Layout,
    params: &[Vec<f64>],
    readings: &[f64],
    pose: &mut [f64; 6],
    joints: &mut [Vec<f64>],
) -> Result<f64, KinematicsError> {
    let unknowns = layout.pose.len() + layout.passive.iter().map(Vec::len).sum::<usize>();
    let equations: usize = mechanism.legs.iter().map(|l| l.closure_dims).sum();
    if unknowns != equations {
        return Err(KinematicsError::NotAssemblable {
            residual: f64::INFINITY,
        });
    }
    let geometries: Vec<_> = mechanism
        .legs
        .iter()
        .zip(params)
        .map(|(l, p)| l.geometry(p))
        .collect();
    for (l, leg) in mechanism.legs.iter().enumerate() {
        joints[l][leg.actuated] = geometries[l].gain * readings[l] + geometries[l].offset;
    }
    let mut residual = f64::INFINITY;
    for _ in 0..=MAX_ITERATIONS {
        let mut f = DVector::zeros(equations);
        let mut jacobian = DMatrix::zeros(equations, unknowns);
        let mut row = 0;
        let mut column = layout.pose.len();
        let pose_dual = pose.map(Dual64::from);
        for (l, leg) in mechanism.legs.iter().enumerate() {
            let geometry = &geometries[l];
            let (tip, tip_jacobian) = tip_and_jacobian(leg, geometry, &joints[l]);
            let target = attachment_world(pose, &geometry.attachment);
            let attachment_dual = geometry.attachment.map(Dual64::from);
            for (k, &c) in layout.pose.iter().enumerate() {
                let mut seeded = pose_dual;
                seeded[c].eps = 1.0;
                let moved = attachment_world(&seeded, &attachment_dual);
                for d in 0..leg.closure_dims {
                    jacobian[(row + d, k)] = -moved[d].eps;
                }
            }
            for &p in &layout.passive[l] {
                for d in 0..leg.closure_dims {
                    jacobian[(row + d, column)] = tip_jacobian[(d, p)];
                }
                column += 1;
            }
            for d in 0..leg.closure_dims {
                f[row + d] = tip[d] - target[d];
            }
            row += leg.closure_dims;
        }
        let previous = residual;
        residual = f.norm();
        if !residual.is_finite() {
            return Err(KinematicsError::NotAssemblable { residual });
        }
        if residual < 1e-13 || (residual < 1e-10 && residual >= 0.5 * previous) {
            let mut normalised = jacobian.clone();
            for mut c in normalised.column_iter_mut() {
                let n = c.norm();
                if n > 0.0 {
                    c /= n;
                }
            }
            let determinant = normalised.determinant();
            if determinant.abs() < 1e-10 {
                return Err(KinematicsError::AssemblyModeChange);
            }
            return Ok(determinant);
        }
        let Some(step) = jacobian.lu().solve(&(-f)) else {
            return Err(KinematicsError::NotAssemblable { residual });
        };
        let largest = step.amax();
        let scale = if largest > 0.5 { 0.5 / largest } else { 1.0 };
        for (k, &c) in layout.pose.iter().enumerate() {
            pose[c] += scale * step[k];
        }
        let mut column = layout.pose.len();
        for (l, leg) in mechanism.legs.iter().enumerate() {
            for &p in &layout.passive[l] {
                joints[l][p] += scale * step[column];
                if leg.joints[leg.moving[p]].kind == JointKind::Revolute {
                    let home = leg.home_joints[p];
                    joints[l][p] = home + wrap_angle(joints[l][p] - home);
                }
                column += 1;
            }
        }
    }
    Err(KinematicsError::NotAssemblable { residual })
}

/// Every leg's moving joints at home.
fn home_joints(mechanism: &Mechanism) -> Vec<Vec<f64>> {
    mechanism
        .legs
        .iter()
        .map(|l| l.home_joints.clone())
        .collect()
}
