//! What a command writes besides its text: the inputs no output may overwrite, and the report
//! files (`--json`, the `--plots` pictures), written before the text (a closed terminal pipe
//! must not lose them) and then named in it.

use std::path::Path;

use anyhow::Result;

use super::console::Console;
use crate::files::{Input, Output};
use crate::model::Mechanism;

/// An input of the run, `role` for messages ("model file", "measurement file", …).
pub(super) fn input<'a>(role: &'a str, path: &'a Path) -> Input<'a> {
    Input { role, path }
}

/// The inputs every command reads: the model file and its URDF.
pub(super) fn model_inputs<'a>(model: &'a Path, mechanism: &'a Mechanism) -> Vec<Input<'a>> {
    vec![
        input("model file", model),
        input("URDF", &mechanism.urdf_path),
    ]
}

/// The file name of `path` (a model's, for a picture's legend; the URDF's, for the calibrated
/// model that names it), or the whole path if it has none.
pub(super) fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The checked report files of a command: `--json` and one output per `--plots` picture.
#[derive(Debug)]
pub(super) struct ReportFiles {
    /// `--json`, if given.
    pub(super) json: Option<Output>,
    /// The pictures, none without `--plots`.
    pub(super) pictures: Vec<Output>,
}

impl ReportFiles {
    /// The command's text: to standard error when the JSON goes to standard output.
    pub(super) fn console(&self) -> Console {
        Console::new(self.json.as_ref().is_some_and(Output::is_stdout))
    }

    /// Writes the JSON text (`what`, e.g. "JSON report", for messages), made only when asked for.
    pub(super) fn write_json(
        &self,
        what: &str,
        text: impl FnOnce() -> Result<String>,
    ) -> Result<()> {
        if let Some(output) = &self.json {
            output.write(what, text()?.as_bytes())?;
        }
        Ok(())
    }

    /// Writes the pictures (one per output, in order), drawn only when asked for.
    pub(super) fn write_pictures(&self, draw: impl FnOnce() -> Result<Vec<Vec<u8>>>) -> Result<()> {
        if !self.pictures.is_empty() {
            for (output, bytes) in self.pictures.iter().zip(&draw()?) {
                output.write("picture", bytes)?;
            }
        }
        Ok(())
    }

    /// Says where the JSON (`json`, e.g. "JSON report", unless on standard output) and the
    /// pictures were written.
    pub(super) fn say_written(&self, console: &mut Console, json: &str) -> Result<()> {
        if let Some(output) = self.json.as_ref().filter(|o| !o.is_stdout()) {
            console.line(format_args!("\n{json} written to {}", output.name()))?;
        }
        for output in &self.pictures {
            console.line(format_args!("picture written to {}", output.name()))?;
        }
        Ok(())
    }
}
