//! `--plots DIR` and `--png`: the picture format and the checked outputs in the directory.

use std::path::Path;

use super::output::{Input, Output};
use crate::report::plots::Format;

/// SVG, or PNG with `--png`.
pub(super) fn format(png: bool) -> Format {
    if png {
        Format::Png
    } else {
        Format::Svg
    }
}

/// The single picture `name` of a command in `--plots` directory `plots` (if given), checked
/// before any work.
///
/// # Errors
/// As [`prepare`].
pub(super) fn prepare_one(
    plots: Option<&Path>,
    name: &str,
    format: Format,
    inputs: &[Input<'_>],
) -> anyhow::Result<Option<Output>> {
    match plots {
        Some(dir) => Ok(prepare(dir, &[name], format, inputs)?.pop()),
        None => Ok(None),
    }
}

/// Creates `dir` if missing and checks one output per picture `names` (without extension)
/// in it, before any work.
///
/// # Errors
/// `dir` exists and is not a directory or cannot be created; a picture would overwrite an
/// input or cannot be written there.
pub(super) fn prepare(
    dir: &Path,
    names: &[&str],
    format: Format,
    inputs: &[Input<'_>],
) -> anyhow::Result<Vec<Output>> {
    if dir.exists() && !dir.is_dir() {
        anyhow::bail!(
            "{}: --plots expects a directory, found a file; choose another path",
            dir.display()
        );
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "{}: --plots: cannot create the directory: {e}",
            dir.display()
        )
    })?;
    names
        .iter()
        .map(|name| {
            let path = dir.join(format!("{name}.{}", format.extension()));
            Output::prepare("--plots", &path, inputs)
        })
        .collect()
}
