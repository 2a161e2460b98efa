//! Loading a mechanism: the model file cross-checked against its URDF
//! (`Mechanism::unassembled`, values only), then the checks that need the region's geometry
//! ([`crate::workspace::region::check_usable`]: a polyhedron encloses a volume, the margin
//! leaves a usable region) and the kinematics ([`crate::kinematics::assembly`]: home closure
//! and branch, planar axes, platform). The one file of the model that uses the layers above it.

use std::path::Path;

use super::file::ModelFile;
use super::source::read_text;
use super::Mechanism;
use crate::error::{Error, Result};
use crate::kinematics::assembly::assemble;
use crate::workspace::region::check_usable;

impl Mechanism {
    /// Loads and validates a model file and the URDF it names.
    ///
    /// # Errors
    /// [`Error::Io`] if the model file cannot be read or is not a regular file (or is `-`,
    /// standard input), [`Error::Model`] on field `urdf` if the URDF cannot be (empty name, not
    /// found, not a regular file, unreadable), then as [`Mechanism::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        if path.as_os_str() == "-" {
            return Err(Error::Io {
                path: path.to_path_buf(),
                error: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "standard input cannot hold the model (its URDF is found beside the model \
                     file): give the model file's path; `-` is only for the measurements",
                ),
            });
        }
        let text = read_text(path).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let file = ModelFile::parse(&text, path)?;
        if file.urdf.trim().is_empty() {
            return Err(Error::Model {
                path: path.to_path_buf(),
                field: "urdf".into(),
                message: "expected the URDF file's name (relative to the model file), found an \
                          empty value"
                    .into(),
            });
        }
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
        checked(Self::unassembled(path, file, &urdf_path, &urdf_text)?)
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
        checked(Self::unassembled(model_path, file, urdf_path, urdf_text)?)
    }
}

/// The geometric and kinematic checks of a cross-checked mechanism. A home configuration that
/// does not close names the leg's joints the URDF gives no `<axis>` (urdf-rs then takes x,
/// silently): a forgotten or misplaced axis is the likely cause.
fn checked((mechanism, implicit_axes): (Mechanism, Vec<String>)) -> Result<Mechanism> {
    check_usable(&mechanism.workspace, &mechanism.model_path)?;
    let hints: Vec<(String, Vec<String>)> = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| {
            let joints = leg.joints.iter().map(|j| &j.name);
            let implicit = joints.filter(|j| implicit_axes.contains(j)).cloned();
            (format!("legs[{l}].home"), implicit.collect())
        })
        .collect();
    assemble(mechanism).map_err(|error| match error {
        Error::Model {
            path,
            field,
            message,
        } if message.starts_with("the home configuration does not close") => {
            let implicit = hints.iter().find(|(f, _)| *f == field).map(|(_, j)| j);
            let message = match implicit {
                Some(joints) if !joints.is_empty() => format!(
                    "{message} (the URDF gives no <axis> to joint {}: it moves along or about \
                     its frame's x axis, the URDF default; write the <axis> meant)",
                    joints
                        .iter()
                        .map(|j| format!("`{j}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                _ => message,
            };
            Error::Model {
                path,
                field,
                message,
            }
        }
        other => other,
    })
}
