//! The pictures of `identify --plots DIR` and `evaluate --plots DIR`: which figures, from which
//! reports, under which file names.

use super::canvas::{render, Format};
use super::distribution::{ErrorDistribution, ErrorSample};
use super::error_map::{ErrorMapFigure, MapPanel};
use super::parameter_errors::ParameterErrors;
use crate::error::{Error, Result};
use crate::evaluate::held_out::Evaluation;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::report::Report;

/// File name (without extension) of the parameter-error picture.
pub const PARAMETER_ERRORS: &str = "parameter-errors";
/// File name (without extension) of the accuracy-map picture.
pub const ACCURACY_MAP: &str = "accuracy-map";
/// File name (without extension) of the position-error distribution.
pub const POSITION_ERRORS: &str = "position-errors";

/// The file names (without extension) [`identify_pictures`] draws, with or without maps.
pub fn identify_picture_names(maps: bool) -> Vec<&'static str> {
    let mut names = vec![PARAMETER_ERRORS];
    if maps {
        names.push(ACCURACY_MAP);
    }
    names
}

/// The identification pictures, in the order of [`identify_picture_names`]: the parameter
/// errors (needs the real values) and, when the report has maps, the accuracy map with the
/// identification poses (x, y) on it.
///
/// # Errors
/// The report has no real values (measurements from a file), or a picture cannot be drawn.
pub fn identify_pictures(report: &Report<'_>, format: Format) -> Result<Vec<Vec<u8>>> {
    let errors = ParameterErrors::from_report(report).ok_or_else(|| {
        Error::Invalid(
            "--plots: the parameter errors need the real values, known only in simulation".into(),
        )
    })?;
    let mut pictures = vec![render(&errors, format)?];
    if let Some(maps) = &report.maps {
        let poses: Vec<[f64; 2]> = report
            .measurements
            .poses()
            .map_or(&[][..], |set| set.poses())
            .iter()
            .map(|p| [p.pose[0], p.pose[1]])
            .collect();
        let mut panels = vec![MapPanel::from_map("before (nominal model)", &maps.before)];
        for (result, map) in report.results.iter().zip(&maps.after) {
            panels.push(MapPanel::from_map(
                &format!("after: {}", result.strategy.name()),
                map,
            ));
        }
        let figure = ErrorMapFigure {
            title: format!(
                "{}: position error over {} of the workspace region{}",
                report.mechanism.name,
                maps.before.scale,
                map_slice(report.mechanism)
                    .map_or(String::new(), |slice| format!(", {slice}; poses projected"))
            ),
            grid_m: maps.before.grid_m,
            panels,
            poses,
        };
        pictures.push(render(&figure, format)?);
    }
    Ok(pictures)
}

/// Which slice of a spatial model's workspace the accuracy map shows (the grid is in x, y;
/// every other coordinate at its home value, see [`crate::evaluate::accuracy::map_grid`]);
/// `None` for a planar model.
pub fn map_slice(mechanism: &Mechanism) -> Option<String> {
    if mechanism.is_planar() {
        return None;
    }
    let home = |c: usize| crate::report::tidy(mechanism.home_pose[c], 4).to_string();
    let mut slice = format!("slice z = {} m", home(2));
    let angles: Vec<usize> = (3..6).filter(|c| mechanism.measured.contains(c)).collect();
    if !angles.is_empty() {
        let list = |f: &dyn Fn(usize) -> String| -> String {
            angles.iter().map(|&c| f(c)).collect::<Vec<_>>().join(", ")
        };
        let names = list(&|c| COORDINATES[c].to_string());
        let values = list(&home);
        if angles.len() == 1 {
            slice.push_str(&format!(", {names} = {values} rad"));
        } else {
            slice.push_str(&format!(", ({names}) = ({values}) rad"));
        }
    }
    Some(slice)
}

/// What the evaluation picture's errors are, singular: `position error`; through an
/// instrument that reports only some of a target's position coordinates, those
/// (`height error` for `z` alone, as a bed probe's touches; `target (x, y) error`).
pub fn error_quantity(mechanism: &Mechanism) -> String {
    let Some(instrument) = &mechanism.instrument else {
        return "position error".into();
    };
    let mut seen: Vec<&str> = Vec::new();
    for c in instrument.targets.iter().flat_map(|t| t.coordinates()) {
        if !seen.contains(c) {
            seen.push(c);
        }
    }
    let spatial = instrument.targets.iter().any(|t| t.spatial);
    let position = if spatial { 3 } else { 2 };
    let partial = seen.len() < position && seen.iter().all(|c| ["x", "y", "z"].contains(c));
    match seen.as_slice() {
        ["z"] => "height error".into(),
        _ if partial => format!("target ({}) error", seen.join(", ")),
        _ => "target position error".into(),
    }
}

/// The evaluation picture: the distribution of the errors of each `(name, evaluation)` of
/// `mechanism`'s measurements, the first drawn as "before".
///
/// # Errors
/// The picture cannot be drawn.
pub fn evaluate_picture(
    mechanism: &Mechanism,
    evaluations: &[(&str, &Evaluation)],
    format: Format,
) -> Result<Vec<u8>> {
    let measurements = evaluations
        .first()
        .map_or(String::new(), |(_, e)| e.measurements.clone());
    let quantity = error_quantity(mechanism);
    let figure = ErrorDistribution {
        title: format!("{quantity}s on {measurements}"),
        quantity,
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
    render(&figure, format)
}
