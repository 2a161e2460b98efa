//! The model file checked against its URDF: [`Builder`] turns a parsed [`ModelFile`] into a
//! [`Mechanism`], one topic per submodule. Every error names the file and the field.

use std::path::Path;

use crate::error::{Error, Result};
use crate::model::file::ModelFile;
use crate::model::mechanism::{Mechanism, MechanismParts, COORDINATES};

mod home;
mod instrument;
mod legs;
mod measured_poses;
mod noise;
mod parameters;
mod plausible;
mod polygon;
mod quantities;
mod scale;
mod setup;
mod workspace;

impl Mechanism {
    /// The model file and its URDF cross-checked, before the kinematic checks of
    /// [`crate::workspace::region::check_usable`] and [`crate::kinematics::assembly`] (which solve each leg's home configuration and set its branch): use
    /// [`Mechanism::load`] or [`Mechanism::parse`], which run both.
    ///
    /// # Errors
    /// [`crate::error::Error::Urdf`] (with the line where there is one) or
    /// [`crate::error::Error::Model`] naming the field.
    /// Also gives the names of the URDF's moving joints without an `<axis>` element, for the
    /// messages of the kinematic checks.
    pub(crate) fn unassembled(
        path: &Path,
        file: ModelFile,
        urdf_path: &Path,
        urdf_text: &str,
    ) -> Result<(Self, Vec<String>)> {
        let (robot, implicit_axes) = crate::model::urdf::parse_noting_axes(urdf_text, urdf_path)?;
        let mechanism = Builder {
            path,
            urdf_path,
            robot: &robot,
        }
        .build(file)?;
        Ok((mechanism, implicit_axes))
    }
}

/// Cross-checks a model file against the URDF it names.
pub(super) struct Builder<'a> {
    pub(super) path: &'a Path,
    pub(super) urdf_path: &'a Path,
    pub(super) robot: &'a urdf_rs::Robot,
}

impl Builder<'_> {
    fn error(&self, field: impl Into<String>, message: impl Into<String>) -> Error {
        Error::Model {
            path: self.path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    fn urdf_name(&self) -> String {
        self.urdf_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    pub(super) fn build(&self, file: ModelFile) -> Result<Mechanism> {
        self.magnitudes(&file)?;
        let measured = self.measured(&file.measured)?;
        let home_pose = self.home_pose(&file.home.pose, &measured)?;
        let closure_dims = if measured.contains(&2) { 3 } else { 2 };
        let mut legs = self.legs(&file, closure_dims)?;
        self.parameters(&file.parameters, &mut legs)?;
        let quantities = self.quantities(&file, &mut legs)?;
        self.scale(&file, &legs)?;
        for (index, leg) in legs.iter_mut().enumerate() {
            self.home(leg, index, &file.legs[index].home)?;
        }
        let workspace = self.workspace(&file, &measured)?;
        let noise = match &file.noise {
            Some(entries) => Some(self.noise("noise", entries, &measured)?),
            None => None,
        };
        let instrument = self.instrument(file.instrument.as_ref(), &measured, &legs)?;
        let factor_sets = self.factor_sets(&file, &legs, &quantities, instrument.as_ref())?;
        let simulation = self.simulation(&file, &measured, &legs, noise, instrument.as_ref())?;
        let selection = self.selection(&file, simulation.as_ref())?;
        let mut warnings = self.degree_warnings(&file, &legs);
        warnings.extend(self.urdf_degree_warnings(&legs));
        let mechanism = Mechanism::from_parts(MechanismParts {
            name: file.name,
            model_path: self.path.to_path_buf(),
            urdf_path: self.urdf_path.to_path_buf(),
            mode: file.mode,
            measured,
            home_pose,
            legs,
            workspace,
            selection,
            noise,
            simulation,
            instrument,
            quantities,
            factor_sets,
            prior_covariance: None,
            warnings,
        });
        Ok(mechanism)
    }

    fn measured(&self, names: &[String]) -> Result<Vec<usize>> {
        let mut measured = Vec::new();
        for (i, name) in names.iter().enumerate() {
            let Some(index) = COORDINATES.iter().position(|c| c == name) else {
                return Err(self.error(
                    format!("measured[{i}]"),
                    format!(
                        "unknown coordinate `{name}`; expected one of x, y, z, roll, pitch, yaw"
                    ),
                ));
            };
            if measured.contains(&index) {
                return Err(self.error(
                    format!("measured[{i}]"),
                    format!("`{name}` is listed twice"),
                ));
            }
            measured.push(index);
        }
        if !(measured.contains(&0) && measured.contains(&1)) {
            return Err(self.error("measured", "x and y must be measured"));
        }
        Ok(measured)
    }
}
