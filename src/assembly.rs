//! Loading a mechanism: the model file cross-checked against its URDF by [`crate::model`], then
//! the checks that need the kinematics, which sit above the model: each leg's home
//! configuration must close at the home pose (this fixes its branch, the working mode), a planar
//! model's joints must move in the plane, and the platform must not be degenerate at home.
//! Every error names the model file and the field.

use std::path::Path;

use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::chain::moving_axes;
use crate::kinematics::inverse::newton;
use crate::kinematics::singularity::ParallelMeasure;
use crate::model::file::ModelFile;
use crate::model::joint::JointKind;
use crate::model::source::read_text;
use crate::model::Mechanism;

/// Parallel measure (unit-norm rows, in [−1, 1]) at or below which the home pose is degenerate.
pub const DEGENERATE_PARALLEL_MEASURE: f64 = 1e-8;

impl Mechanism {
    /// Loads and validates a model file and the URDF it names.
    ///
    /// # Errors
    /// [`Error::Io`] if the model file cannot be read or is not a regular file,
    /// [`Error::Model`] on field `urdf` if the URDF cannot be (not found, not a regular file,
    /// unreadable), then as [`Mechanism::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        let text = read_text(path).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let file = ModelFile::parse(&text, path)?;
        let urdf_path = path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(&file.urdf);
        let urdf_text = read_text(&urdf_path).map_err(|error| Error::Model {
            path: path.to_path_buf(),
            field: "urdf".into(),
            message: if error.kind() == std::io::ErrorKind::NotFound {
                format!("URDF file `{}` not found", urdf_path.display())
            } else {
                format!("URDF file `{}`: {error}", urdf_path.display())
            },
        })?;
        assemble(Self::unassembled(path, file, &urdf_path, &urdf_text)?)
    }

    /// Parses and validates model-file text and URDF text (no file is read: the paths are only
    /// used in messages). [`Mechanism::load`] without the file system, e.g. for fuzzing.
    ///
    /// # Errors
    /// [`Error::Yaml`], [`Error::Urdf`] (with the line where there is one) or [`Error::Model`]
    /// naming the field.
    pub fn parse(
        model_text: &str,
        model_path: &Path,
        urdf_text: &str,
        urdf_path: &Path,
    ) -> Result<Self> {
        let file = ModelFile::parse(model_text, model_path)?;
        assemble(Self::unassembled(model_path, file, urdf_path, urdf_text)?)
    }
}

fn model_error(mechanism: &Mechanism, field: impl Into<String>, message: String) -> Error {
    Error::Model {
        path: mechanism.model_path.clone(),
        field: field.into(),
        message,
    }
}

/// Solves every leg's home configuration from its seeds (setting its branch) and checks the
/// platform at home.
fn assemble(mut mechanism: Mechanism) -> Result<Mechanism> {
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
                _ => axis.z.abs() < 1e-9,
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
    let leg = &mut mechanism.legs[index];
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
