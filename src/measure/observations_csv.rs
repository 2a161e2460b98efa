//! Writing observations ([`super::observations`]) as CSV: a measurement set in the columns the
//! reader takes, and the template of a selection's commanded poses for the instrument to fill.

use super::observed::{
    commanded_columns, expected_columns, forward_columns, instrument_of, measured_pose_columns,
    Observations,
};
use super::rows;
use crate::error::Result;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// The CSV text of instrument measurements, in the layout [`read`] expects (exact round trip
/// of every value).
///
/// # Errors
/// [`Error::Model`] if the model has no instrument.
pub fn to_csv(mechanism: &Mechanism, set: &Observations) -> Result<String> {
    let instrument = instrument_of(mechanism)?;
    let extra = forward_columns(mechanism, instrument);
    let targets = instrument.columns().len();
    let readings = mechanism.actuated_names().len();
    let pose_columns = measured_pose_columns(mechanism, instrument);
    let mut lines: Vec<Vec<String>> = set
        .rows
        .iter()
        .map(|row| {
            let mut cells = vec![row
                .leg
                .map_or(String::new(), |l| mechanism.legs[l].name.clone())];
            match row.observed.is_empty() {
                true => cells.extend(std::iter::repeat_n(String::new(), targets)),
                false => cells.extend(row.observed.iter().map(|v| format!("{v}"))),
            }
            cells.extend(row.readings.iter().map(rows::reading_cell));
            for column in &extra {
                cells.push(match column.as_str() {
                    "id" => row.id.clone().unwrap_or_default(),
                    "from" | "to" | "distance" => String::new(),
                    coordinate => row.pose.map_or(String::new(), |pose| {
                        let c = COORDINATES.iter().position(|n| *n == coordinate);
                        format!("{}", pose[c.unwrap_or_default()])
                    }),
                });
            }
            cells
        })
        .collect();
    for distance in &set.distances {
        let id = |k: usize| set.rows[distance.rows[k]].id.clone().unwrap_or_default();
        let mut cells = vec![String::new(); 1 + targets + readings + 1];
        cells.extend([id(0), id(1), format!("{}", distance.value)]);
        cells.extend(std::iter::repeat_n(String::new(), pose_columns.len()));
        lines.push(cells);
    }
    let mut header = expected_columns(mechanism, instrument);
    header.extend(extra);
    Ok(rows::csv_text(&header, lines.into_iter()))
}

/// The CSV template of an experiment through the instrument at the platform poses of `set`
/// (`legwise select`): per row the leg, the pose to command in `pose.<coordinate>` columns,
/// and empty target and reading columns to fill in. Once filled, [`read`] reads it (the pose
/// columns are ignored); unfilled, it refuses the first empty target cell. A forward model's
/// rows carry ids (`t1, t2, …`), and with `instrument.poses` its last `measured` rows are rows
/// whose platform pose is to be measured (ids `m1, m2, …`, the pose's columns `x, y, …` to
/// fill in, the target columns left empty).
///
/// # Errors
/// [`Error::Model`] if the model has no instrument.
pub fn template_csv(
    mechanism: &Mechanism,
    set: &super::MeasurementSet,
    measured: usize,
) -> Result<String> {
    let instrument = instrument_of(mechanism)?;
    let middle = commanded_columns(mechanism)
        .into_iter()
        .chain(instrument.columns());
    let empty = instrument.columns().len() + mechanism.actuated_names().len();
    let pose_columns = measured_pose_columns(mechanism, instrument);
    let pose_cells = pose_columns.len();
    let touches = set.poses.len().saturating_sub(measured);
    let lines = set.poses.iter().enumerate().map(|(k, pose)| {
        let mut cells = super::file::leg_and_pose_cells(mechanism, pose);
        cells.extend(std::iter::repeat_n(String::new(), empty));
        if instrument.forward {
            cells.push(match k < touches {
                true => format!("t{}", k + 1),
                false => format!("m{}", k + 1 - touches),
            });
            cells.extend(std::iter::repeat_n(String::new(), pose_cells));
        }
        cells
    });
    let mut header = rows::columns(mechanism, middle);
    if instrument.forward {
        header.push("id".into());
        header.extend(pose_columns);
    }
    Ok(rows::csv_text(&header, lines))
}
