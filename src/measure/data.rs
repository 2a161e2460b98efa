//! What an identification is given: the legs' readings at measured platform poses, or the
//! targets' coordinates seen by the model's instrument with the readings. The model decides
//! which: a model with an `instrument` block is measured through it.

use std::io::Read;
use std::path::Path;

use super::observations::{self, Observations};
use super::{file, MeasurementSet};
use crate::error::{Error, Result};
use crate::model::Mechanism;

/// The name standard input goes by in messages and reports.
pub const STDIN_NAME: &str = "<stdin>";

/// The measurements of one identification.
#[derive(Debug, Clone, PartialEq)]
pub enum Measurements {
    /// Measured platform poses with the legs' readings.
    Readings(MeasurementSet),
    /// The targets' coordinates in the instrument frame with the legs' readings.
    Targets(Observations),
}

impl Measurements {
    /// The error of platform poses given to `mechanism`, a model with an instrument block.
    pub fn poses_for_an_instrument(mechanism: &Mechanism) -> Error {
        Error::Invalid(format!(
            "{}: the model has an instrument block: its measurements are the targets' \
             coordinates in the instrument frame, not platform poses",
            mechanism.model_path.display()
        ))
    }

    /// Reads the measurement CSV at `path` in the layout `mechanism` expects (docs/models.md).
    ///
    /// # Errors
    /// The file cannot be read, or a line, column or value is wrong (named in the error).
    pub fn read(path: &Path, mechanism: &Mechanism) -> Result<Self> {
        Ok(match mechanism.instrument {
            Some(_) => Measurements::Targets(observations::read(path, mechanism)?),
            None => Measurements::Readings(file::read(path, mechanism)?),
        })
    }

    /// As [`Self::read`], from `reader`, named `name` in messages.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn read_from(mut reader: impl Read, name: &Path, mechanism: &Mechanism) -> Result<Self> {
        Ok(match mechanism.instrument {
            Some(_) => {
                let mut text = String::new();
                reader
                    .read_to_string(&mut text)
                    .map_err(super::rows::io_error(name))?;
                Measurements::Targets(observations::parse(&text, name, mechanism)?)
            }
            None => Measurements::Readings(file::read_from(reader, name, mechanism)?),
        })
    }

    /// Where the measurements came from, for reports: the file, `standard input`, or `None`
    /// for measurements made in memory.
    pub fn origin(&self) -> Option<String> {
        let path = match self {
            Measurements::Readings(set) => set.source.as_deref(),
            Measurements::Targets(observations) => observations.source.as_deref(),
        }?;
        Some(if path == Path::new(STDIN_NAME) {
            "standard input".to_string()
        } else {
            path.display().to_string()
        })
    }

    /// The platform poses measured (`None` for measurements through an instrument, which
    /// measures targets, not poses).
    pub fn poses(&self) -> Option<&MeasurementSet> {
        match self {
            Measurements::Readings(set) => Some(set),
            Measurements::Targets(_) => None,
        }
    }

    /// The measurement CSV of these measurements in the layout `mechanism` reads.
    ///
    /// # Errors
    /// Target coordinates for a model without an instrument block.
    pub fn to_csv(&self, mechanism: &Mechanism) -> Result<String> {
        match self {
            Measurements::Readings(set) => Ok(file::to_csv(mechanism, set)),
            Measurements::Targets(observations) => observations::to_csv(mechanism, observations),
        }
    }

    /// Whether `model` and `other` read the same measurement file: both platform poses, or
    /// both the same target columns through their instruments.
    ///
    /// # Errors
    /// [`Error::Invalid`] saying what each reads.
    pub fn same_layout(model: &Mechanism, other: &Mechanism) -> Result<()> {
        let columns = |m: &Mechanism| m.instrument.as_ref().map(|i| i.columns());
        let describe = |m: &Mechanism| {
            columns(m).map_or_else(
                || "platform poses".to_string(),
                |c| {
                    format!(
                        "target coordinates through its instrument ({})",
                        c.join(", ")
                    )
                },
            )
        };
        if columns(model) == columns(other) {
            return Ok(());
        }
        Err(Error::Invalid(format!(
            "its measurements are {}, those of {} are {}; both models must read the same \
             measurement file",
            describe(other),
            model.model_path.display(),
            describe(model)
        )))
    }

    /// Rows of the measurement file (measured poses, or rows of target coordinates).
    pub fn rows(&self) -> usize {
        match self {
            Measurements::Readings(set) => set.len(),
            Measurements::Targets(observations) => observations.rows.len(),
        }
    }
}
