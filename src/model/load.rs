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

/// The geometric and kinematic checks of a cross-checked mechanism.
fn checked(mechanism: Mechanism) -> Result<Mechanism> {
    check_usable(&mechanism.workspace, &mechanism.model_path)?;
    assemble(mechanism)
}
