//! The kinematic checks of a loaded mechanism (run by [`Mechanism::load`] and
//! [`Mechanism::parse`] after the model file has been cross-checked against its URDF): each
//! leg's home configuration must close at the home pose (this fixes its branch, the working
//! mode) within the joints' URDF limits, a planar model's joints must move in the plane, and the platform must not be
//! degenerate at home. Every error names the model file and the field.

use super::chain::moving_axes;
use super::inverse::newton;
use super::singularity::ParallelMeasure;
use crate::error::{Error, JointBeyondLimits, KinematicsError, Result};
use crate::model::joint::JointKind;
use crate::model::Mechanism;

/// Parallel measure (unit-norm rows, in [−1, 1]) at or below which the home pose is degenerate.
pub const DEGENERATE_PARALLEL_MEASURE: f64 = 1e-8;

fn model_error(mechanism: &Mechanism, field: impl Into<String>, message: String) -> Error {
    Error::Model {
        path: mechanism.model_path.clone(),
        field: field.into(),
        message,
    }
}

/// Solves every leg's home configuration from its seeds (setting its branch) and checks the
/// platform at home.
///
/// # Errors
/// [`Error::Model`] naming the leg's `chain` or `home`, or the legs' attachments.
pub(crate) fn assemble(mut mechanism: Mechanism) -> Result<Mechanism> {
    for index in 0..mechanism.legs.len() {
        home(&mut mechanism, index)?;
    }
    platform(&mechanism)?;
    Ok(mechanism)
}

/// Leg `index`'s home configuration: planar axes for a planar leg, closure at the home pose
/// by Newton from the file's seeds, the branch from the solution's determinant.
fn home(mechanism: &mut Mechanism, index: usize) -> Result<()> {
    let home_pose = mechanism.home_pose;
    let leg = &mechanism.legs[index];
    let seed = leg.home_joints.clone();
    let geometry = leg.geometry(&leg.nominal());
    if leg.closure_dims == 2 {
        // A planar model: revolute joints must turn about z, prismatic ones slide in x, y.
        let axes = moving_axes(leg, &geometry, &seed);
        for ((kind, axis), &j) in axes.iter().zip(&leg.moving) {
            let planar = match kind {
                JointKind::Revolute => axis.z.abs() > 1.0 - 1e-9,
                JointKind::Prismatic => axis.z.abs() < 1e-9,
                JointKind::Fixed => true,
            };
            if !planar {
                let name = &leg.joints[j].name;
                return Err(model_error(
                    mechanism,
                    format!("legs[{index}].chain"),
                    format!(
                        "joint `{name}` has world axis ({:.3}, {:.3}, {:.3}) at home; a planar model (z not measured) needs revolute axes along z and prismatic axes in the x-y plane (check its <axis> in the URDF)",
                        axis.x, axis.y, axis.z
                    ),
                ));
            }
        }
    }
    let solution = newton(leg, &geometry, &home_pose, &seed).map_err(|err| {
        model_error(
            mechanism,
            format!("legs[{index}].home"),
            format!("the home configuration does not close at the home pose: {err}"),
        )
    })?;
    // The home configuration is one the leg can take: within every joint's URDF <limit> (a
    // home beyond a stroke was accepted, and only pose selection found no usable pose).
    let limits = leg.moving.iter().zip(&solution.q).find_map(|(&j, &value)| {
        let joint = &leg.joints[j];
        let [lower, upper] = joint.limits?;
        (!(lower..=upper).contains(&value)).then(|| JointBeyondLimits {
            leg: leg.name.clone(),
            joint: joint.name.clone(),
            value,
            lower,
            upper,
        })
    });
    if let Some(beyond) = limits {
        return Err(model_error(
            mechanism,
            format!("legs[{index}].home"),
            format!(
                "the home configuration is outside the URDF joint limits: {beyond} (check the \
                 home pose, the leg's home values and the <limit> in the URDF)"
            ),
        ));
    }
    let leg = &mut mechanism.parts_mut().legs[index];
    leg.branch_sign = solution.normalised_determinant.signum();
    leg.home_joints = solution.q;
    Ok(())
}

/// The platform at home: with as many legs as measured coordinates, the parallel (type II)
/// measure must not vanish there. A degenerate platform (attachment points that coincide or
/// line up) can move with every actuator locked: forward kinematics, the assembly mode and
/// pose selection all break down, so it is refused when the model is loaded.
fn platform(mechanism: &Mechanism) -> Result<()> {
    let measure = match ParallelMeasure::new(mechanism, mechanism.nominal_parameters()) {
        Ok(measure) => measure.at(&mechanism.home_pose).map_err(|e| e.to_string()),
        Err(KinematicsError::NotSquare { .. }) => return Ok(()),
        Err(KinematicsError::AssemblyModeChange) => Ok(0.0),
        Err(other) => Err(other.to_string()),
    };
    let value = match measure {
        Ok(value) if value.abs() > DEGENERATE_PARALLEL_MEASURE => return Ok(()),
        Ok(value) => format!("{value:.1e}"),
        Err(message) => format!("undefined ({message})"),
    };
    Err(model_error(
        mechanism,
        "legs[*].attachment",
        format!(
            "the platform is degenerate at the home pose: its parallel (type II) measure is \
             {value} (0: the platform moves with every actuator locked); the attachment points \
             must not coincide or line up, and the legs must not all meet in one point or lie \
             in one plane with the platform"
        ),
    ))
}
