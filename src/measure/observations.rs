//! Measurements of a model with an `instrument` block: per row, what the instrument reports of
//! its targets (in its own frame) and the actuator readings.
//!
//! CSV columns: `leg` (optional, as in [`super::file`]), then every target's coordinates, named
//! `<coordinate>.<target>` (`x.r1, y.r1, x.r2, y.r2`; a pose target adds `yaw.<target>`; a
//! spatial model's targets add `z.<target>`, its pose targets `roll.`, `pitch.`, `yaw.<target>`),
//! then one column per actuated joint with its raw reading. The target columns are always suffixed,
//! even for a single target: a file of platform poses (`x, y, …`) is never read as target
//! coordinates by mistake. Optional columns `pose.<coordinate>` (`pose.x, pose.y, …`, the
//! model's measured coordinates) hold the platform pose commanded at the row, as
//! [`template_csv`] writes them for `legwise select`; they are read past and never used, but
//! for a model seen through the forward kinematics whose row has no reading: its readings are
//! then the nominal model's inverse kinematics of the commanded pose (what a controller
//! running the nominal model logs). A forward model's rows may carry an `id`, and distance
//! rows `from`, `to` and `distance`; with `instrument.poses`, a row may carry a platform pose
//! measured in the base frame in the model's pose columns, unprefixed (`x, y, z`, as in a file
//! of platform poses), with or without target coordinates (docs/models.md §10).
//! Errors name the file, the line and the column.

use std::path::Path;

use super::checks::{mechanism_size, SIZE_FACTOR};
use super::line_endings::Lines;
use super::rows;
use crate::error::Result;
use crate::kinematics::inverse::predict_reading;
use crate::model::Mechanism;

pub use super::observations_csv::{template_csv, to_csv};
use super::observed::{
    commanded_columns, expected_columns, forward_columns, measured_pose_columns,
};
pub use super::observed::{instrument_of, DistanceRow, Observations, ObservedRow};
use super::observed_rows::{distance_row, repeated_rows, resolve_distances};

/// Reads an instrument measurement file for `mechanism`.
///
/// # Errors
/// [`Error::Io`](crate::error::Error::Io) if unreadable; [`Error::Model`](crate::error::Error::Model) if the model has no instrument;
/// [`Error::Measurement`](crate::error::Error::Measurement) naming the line and column for a missing or unknown column, an
/// unknown leg, a non-numeric or non-finite cell, a missing coordinate, a target position
/// farther from the instrument than the mechanism could put it (millimetres?), or no rows.
pub fn read(path: &Path, mechanism: &Mechanism) -> Result<Observations> {
    let text = std::fs::read_to_string(path).map_err(rows::io_error(path))?;
    parse(&text, path, mechanism)
}

/// Parses instrument measurement CSV text; `path` is only used in messages.
///
/// # Errors
/// As [`read`].
pub fn parse(text: &str, path: &Path, mechanism: &Mechanism) -> Result<Observations> {
    let instrument = instrument_of(mechanism)?;
    let fail = |location: String, message: String| rows::fail(path, location, message);
    let expected = expected_columns(mechanism, instrument);
    let commanded = commanded_columns(mechanism);
    let forward_optional = forward_columns(mechanism, instrument);
    let mut listing = match instrument.forward {
        false => format!(
            "{} (and optionally {}, ignored)",
            expected.join(", "),
            commanded.join(", ")
        ),
        true => format!(
            "{} (and optionally {}: the commanded pose of a row without readings; {})",
            expected.join(", "),
            commanded.join(", "),
            forward_optional.join(", ")
        ),
    };
    if instrument.forward && instrument.distances.is_none() {
        listing.push_str(
            "; distance rows (from, to, distance) need the model's `instrument.distances`",
        );
    }
    let mut optional = commanded;
    optional.extend(forward_optional);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(Lines::new(text.as_bytes()));
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| fail("header".into(), e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    rows::check_header(path, &header, &expected, &optional, &listing)?;
    let index = |name: &str| header.iter().position(|h| h == name).unwrap_or_default();
    let leg_column = header.iter().position(|h| h == "leg");
    let column_of = |name: &str| header.iter().position(|h| h == name);
    let (id_column, distance_columns) = (
        column_of("id"),
        [column_of("from"), column_of("to"), column_of("distance")],
    );
    let mut pending = Vec::new();
    // The commanded pose's columns present (forward models read them when a row has no
    // reading).
    let commanded_at: Vec<usize> = commanded_columns(mechanism)
        .iter()
        .filter_map(|name| column_of(name))
        .collect();
    let commanded_at = match commanded_at.len() == mechanism.measured.len() {
        true => commanded_at,
        false => Vec::new(),
    };
    let target_columns: Vec<usize> = instrument.columns().iter().map(|c| index(c)).collect();
    // The measured pose's columns present (all of them, or none).
    let pose_names = measured_pose_columns(mechanism, instrument);
    let pose_at: Vec<usize> = pose_names.iter().filter_map(|n| column_of(n)).collect();
    if !pose_at.is_empty() && pose_at.len() != pose_names.len() {
        let missing = pose_names.iter().find(|n| column_of(n).is_none());
        return Err(fail(
            "header".into(),
            format!(
                "a measured pose needs every coordinate the model measures ({}); column `{}` \
                 is missing",
                pose_names.join(", "),
                missing.map_or("", String::as_str)
            ),
        ));
    }
    let reading_columns: Vec<usize> = mechanism
        .actuated_names()
        .iter()
        .map(|name| index(name))
        .collect();
    // No target the mechanism carries is farther from the instrument than the mechanism's
    // size (times the factor of the plain measurement checks) plus the frame's distance.
    let size = mechanism_size(mechanism);
    let frame: f64 = instrument
        .parameters
        .iter()
        .filter(|p| ["frame_x", "frame_y", "frame_z"].contains(&p.name.as_str()))
        .map(|p| p.nominal * p.nominal)
        .sum::<f64>()
        .sqrt();
    let reach = SIZE_FACTOR * size + frame;
    let mut rows = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let line = e
                    .position()
                    .map_or(0, |p| reader.get_ref().line_at(p.byte()));
                return Err(fail(format!("line {line}"), e.to_string()));
            }
        }
        let line = record
            .position()
            .map_or(0, |p| reader.get_ref().line_at(p.byte()) as usize);
        if record.iter().all(str::is_empty) {
            continue;
        }
        let cell = |column: usize| record.get(column).unwrap_or("");
        let number =
            |column: usize| rows::number(path, line, &header[column], cell(column), "SI units");
        let leg = rows::leg_of(path, line, mechanism, leg_column.map_or("", cell))?;
        let id = id_column
            .map(cell)
            .filter(|c| !c.is_empty())
            .map(str::to_string);
        if let [Some(from), Some(to), Some(distance)] = distance_columns {
            let names_rows = !(cell(from).is_empty() && cell(to).is_empty());
            if names_rows && cell(distance).is_empty() {
                return Err(fail(
                    format!("line {line}, column `distance`"),
                    format!(
                        "missing distance: the row names `from` `{}` and `to` `{}`, a distance                          row; expected the distance measured between them in metres",
                        cell(from),
                        cell(to)
                    ),
                ));
            }
            if !cell(distance).is_empty() {
                let cells = (cell(from), cell(to), cell(distance));
                let mut other = target_columns.iter().chain(&reading_columns).copied();
                if let Some(column) = other.find(|&c| !cell(c).is_empty()) {
                    return Err(fail(
                        format!("line {line}, column `{}`", header[column]),
                        "a distance row holds only `from`, `to` and `distance`: the readings \
                         and coordinates are those of the rows it names"
                            .into(),
                    ));
                }
                pending.push(distance_row(
                    path,
                    line,
                    &header,
                    [from, to, distance],
                    cells,
                )?);
                continue;
            }
        }
        // A measured pose: every coordinate, or none (a row without one).
        let pose = match pose_at.iter().any(|&c| !cell(c).is_empty()) {
            false => None,
            true => {
                let mut pose = mechanism.home_pose;
                for (&c, &column) in mechanism.measured.iter().zip(&pose_at) {
                    pose[c] = number(column)?.ok_or_else(|| {
                        fail(
                            format!("line {line}, column `{}`", header[column]),
                            "missing value; expected the measured pose's coordinate (metres \
                             or radians), or none of them for a row without a measured pose"
                                .into(),
                        )
                    })?;
                }
                Some(pose)
            }
        };
        let target_cells = target_columns.iter().map(|&c| cell(c));
        let readings_only = (instrument.distances.is_some() || pose.is_some())
            && target_cells.clone().all(str::is_empty);
        let observed = target_columns
            .iter()
            .filter(|_| !readings_only)
            .map(|&column| {
                number(column)?.ok_or_else(|| {
                    fail(
                        format!("line {line}, column `{}`", header[column]),
                        "missing value; expected the target's coordinate (metres or radians)"
                            .into(),
                    )
                })
            });
        let observed = observed.collect::<Result<Vec<f64>>>()?;
        for (&column, &value) in target_columns.iter().zip(&observed) {
            let position = ["x.", "y.", "z."]
                .iter()
                .any(|c| header[column].starts_with(c));
            if position && value.abs() > reach {
                return Err(fail(
                    format!("line {line}, column `{}`", header[column]),
                    format!(
                        "{value} m is more than {SIZE_FACTOR} times the mechanism's size \
                         ({size:.3} m) from the instrument: positions in millimetres instead \
                         of metres?"
                    ),
                ));
            }
        }
        let readings = reading_columns.iter().map(|&column| number(column));
        let mut readings = readings.collect::<Result<Vec<_>>>()?;
        let commanded = commanded_at.iter().any(|&c| !cell(c).is_empty());
        if instrument.forward && commanded && readings.iter().all(Option::is_none) {
            // Logged as the commanded pose: the nominal model's inverse kinematics of it.
            let values = commanded_at.iter().map(|&column| {
                number(column)?.ok_or_else(|| {
                    fail(
                        format!("line {line}, column `{}`", header[column]),
                        "missing value; expected the commanded pose's coordinate (metres or \
                         radians), or every leg's reading"
                            .into(),
                    )
                })
            });
            let values = values.collect::<Result<Vec<f64>>>()?;
            readings = commanded_readings(mechanism, &values)
                .map_err(|message| {
                    let column = &header[commanded_at[0]];
                    fail(format!("line {line}, column `{column}`"), message)
                })?
                .into_iter()
                .map(Some)
                .collect();
        }
        rows::require_leg_reading(path, line, mechanism, leg, &readings)?;
        if instrument.forward {
            // A row of a measured pose alone predicts the readings it has.
            let every_reading = pose.is_none() || !observed.is_empty();
            forward_row(path, line, mechanism, (leg, every_reading), &readings)?;
        }
        rows.push(ObservedRow {
            line: Some(line),
            leg,
            observed,
            readings,
            id,
            pose,
        });
    }
    if rows.is_empty() {
        return Err(rows::no_rows(path));
    }
    if instrument.forward {
        repeated_rows(path, &rows)?;
    }
    let distances = resolve_distances(path, &rows, pending)?;
    Ok(Observations {
        source: Some(path.to_path_buf()),
        rows,
        distances,
    })
}

/// The readings the nominal model commands for the platform pose of measured coordinates
/// `values` (the model's `measured` order, the others at home): each leg's inverse kinematics,
/// as a controller running the nominal model logs them.
///
/// # Errors
/// A leg of the nominal model that cannot reach the pose, named.
fn commanded_readings(
    mechanism: &Mechanism,
    values: &[f64],
) -> std::result::Result<Vec<f64>, String> {
    let home = mechanism.home_pose;
    let mut pose = home;
    for (&c, &value) in mechanism.measured.iter().zip(values) {
        pose[c] = value;
    }
    mechanism
        .legs
        .iter()
        .map(|leg| {
            predict_reading(leg, &leg.nominal(), &pose, &home).map_err(|error| {
                format!(
                    "the nominal model cannot reach the commanded pose {} (leg `{}`: {error}): \
                     check the pose's units and that it is inside the workspace",
                    mechanism.pose_text(&pose),
                    leg.name
                )
            })
        })
        .collect()
}

/// A row of a model seen through the forward kinematics: every leg's reading, no leg label
/// (the row is one configuration of the whole mechanism).
fn forward_row(
    path: &Path,
    line: usize,
    mechanism: &Mechanism,
    (leg, every_reading): (Option<usize>, bool),
    readings: &[Option<f64>],
) -> Result<()> {
    if let Some(l) = leg {
        return Err(rows::fail(
            path,
            format!("line {line}, column `leg`"),
            format!(
                "`{}`: the model's instrument is seen through the forward kinematics \
                 (`instrument.kinematics: forward`), where a row is every leg's reading at one \
                 configuration: leave `leg` empty",
                mechanism.legs[l].name
            ),
        ));
    }
    let missing = readings.iter().position(Option::is_none);
    if let Some(l) = missing.filter(|_| every_reading) {
        return Err(rows::fail(
            path,
            format!("line {line}, column `{}`", mechanism.actuated_names()[l]),
            "missing reading: the forward kinematics (`instrument.kinematics: forward`) needs \
             every leg's reading at every row"
                .into(),
        ));
    }
    if readings.iter().all(Option::is_none) {
        return Err(rows::fail(
            path,
            format!("line {line}"),
            "no reading: a row of a measured pose predicts the readings it holds".into(),
        ));
    }
    Ok(())
}
