//! The pictures of `identify --plots DIR` and `evaluate --plots DIR`: which figures, from which
//! reports, under which file names.

use std::path::{Path, PathBuf};

use super::canvas::{render, Figure, Format};
use super::distribution::{ErrorDistribution, ErrorSample};
use super::error_map::{ErrorMapFigure, MapPanel};
use super::output::{ensure_directory, write_new};
use super::parameter_errors::ParameterErrors;
use crate::error::{Error, Result};
use crate::evaluate::accuracy::AccuracyMap;
use crate::evaluate::held_out::Evaluation;
use crate::report::IdentifyReport;

/// File name (without extension) of the parameter-error picture.
pub const PARAMETER_ERRORS: &str = "parameter-errors";
/// File name (without extension) of the accuracy-map picture.
pub const ACCURACY_MAP: &str = "accuracy-map";
/// File name (without extension) of the position-error distribution.
pub const POSITION_ERRORS: &str = "position-errors";

/// The accuracy maps of one identification: the nominal model's, then one per result.
#[derive(Debug, Clone, Copy)]
pub struct Maps<'a> {
    /// The nominal model's map.
    pub before: &'a AccuracyMap,
    /// One map per strategy, in the report's order.
    pub after: &'a [AccuracyMap],
}

fn write_one(
    figure: &impl Figure,
    dir: &Path,
    name: &str,
    format: Format,
    inputs: &[&Path],
) -> Result<PathBuf> {
    let path = dir.join(format!("{name}.{}", format.extension()));
    write_new(&path, &render(figure, format)?, inputs)?;
    Ok(path)
}

/// Writes the identification pictures into `dir`: the parameter errors (needs the real values)
/// and, when `maps` are given, the accuracy map with the identification `poses` (x, y) on it.
/// Returns the files written.
///
/// # Errors
/// The report has no real values (measurements from a file); the directory cannot be created
/// or a picture cannot be drawn or written.
pub fn write_identify_plots(
    dir: &Path,
    format: Format,
    report: &IdentifyReport<'_>,
    maps: Option<Maps<'_>>,
    poses: &[[f64; 2]],
    inputs: &[&Path],
) -> Result<Vec<PathBuf>> {
    let errors = ParameterErrors::from_report(report).ok_or_else(|| {
        Error::Invalid(
            "--plots: the parameter errors need the real values, known only in simulation".into(),
        )
    })?;
    ensure_directory(dir)?;
    let mut written = vec![write_one(&errors, dir, PARAMETER_ERRORS, format, inputs)?];
    if let Some(maps) = maps {
        let mut panels = vec![MapPanel::from_map("before (nominal model)", maps.before)];
        for (result, map) in report.results.iter().zip(maps.after) {
            panels.push(MapPanel::from_map(
                &format!("after: {}", result.strategy.name()),
                map,
            ));
        }
        let figure = ErrorMapFigure {
            title: format!(
                "{}: position error over {} of the workspace region",
                report.mechanism.name, maps.before.scale
            ),
            grid_m: maps.before.grid_m,
            panels,
            poses: poses.to_vec(),
        };
        written.push(write_one(&figure, dir, ACCURACY_MAP, format, inputs)?);
    }
    Ok(written)
}

/// Writes the evaluation picture into `dir`: the distribution of position errors of each
/// `(name, evaluation)`, the first drawn as "before". Returns the file written.
///
/// # Errors
/// The directory cannot be created or the picture cannot be drawn or written.
pub fn write_evaluate_plots(
    dir: &Path,
    format: Format,
    evaluations: &[(&str, &Evaluation)],
    inputs: &[&Path],
) -> Result<PathBuf> {
    let measurements = evaluations
        .first()
        .map_or(String::new(), |(_, e)| e.measurements.clone());
    let figure = ErrorDistribution {
        title: format!("position errors on {measurements}"),
        samples: evaluations
            .iter()
            .map(|(name, evaluation)| ErrorSample {
                name: (*name).to_string(),
                errors_m: evaluation
                    .row_errors
                    .iter()
                    .filter_map(|r| r.position_error)
                    .collect(),
            })
            .collect(),
    };
    ensure_directory(dir)?;
    write_one(&figure, dir, POSITION_ERRORS, format, inputs)
}
