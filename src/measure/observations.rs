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

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::checks::{mechanism_size, SIZE_FACTOR};
use super::line_endings::Lines;
use super::rows;
use crate::error::{Error, Result};
use crate::kinematics::inverse::predict_reading;
use crate::model::instrument::Instrument;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// One row: the targets as the instrument reports them, and the readings taken there.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservedRow {
    /// Line in the source file (1-based, the header is line 1), if read from a file.
    pub line: Option<usize>,
    /// The leg whose identification set the row belongs to; `None` for a row shared by all.
    pub leg: Option<usize>,
    /// Every target's coordinates in the instrument frame, in column order (metres, radians).
    pub observed: Vec<f64>,
    /// Raw reading of each leg's actuated joint, `None` when not read.
    pub readings: Vec<Option<f64>>,
    /// The row's label in the `id` column (forward models), which distances name.
    pub id: Option<String>,
    /// The platform pose measured at the row in the base frame `[x, y, z, roll, pitch, yaw]`
    /// (the coordinates the model does not measure at home), if the model's `instrument.poses`
    /// lets rows carry one: each leg's reading is then predicted from it too.
    pub pose: Option<[f64; 6]>,
}

/// A measured distance between one target's positions at two rows (forward models: the
/// model's `instrument.distances`).
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceRow {
    /// Line in the source file, if read from one.
    pub line: Option<usize>,
    /// The two rows (indices into [`Observations::rows`]).
    pub rows: [usize; 2],
    /// The measured distance, metres.
    pub value: f64,
}

/// A set of instrument measurements.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Observations {
    /// The file the measurements came from, if any.
    pub source: Option<PathBuf>,
    /// The rows, in file order.
    pub rows: Vec<ObservedRow>,
    /// Measured distances between rows, in file order (forward models).
    pub distances: Vec<DistanceRow>,
}

impl Observations {
    /// Checks every distance row: it joins two different rows of these observations and
    /// measures a finite length, and no two join the same rows (either way round) (the reader
    /// checks a file's; observations made in memory are checked here before use).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the first bad distance (its line, or its index) and what it
    /// holds.
    pub fn check_distances(&self) -> Result<()> {
        let count = self.rows.len();
        for (k, d) in self.distances.iter().enumerate() {
            let [a, b] = d.rows;
            if a >= count || b >= count || a == b || !d.value.is_finite() {
                let at = d
                    .line
                    .map_or(format!("distance {k}"), |l| format!("line {l}"));
                return Err(Error::Invalid(format!(
                    "{at}: a distance joins two different rows of the {count} and measures a \
                     finite length; found rows {a} and {b}, {} m",
                    d.value
                )));
            }
        }
        if let Some((k, first)) = repeated_pair(&self.distances) {
            let [a, b] = self.distances[k].rows;
            return Err(Error::Invalid(format!(
                "distance {k}: joins rows {a} and {b}, as distance {first} does: a distance \
                 given twice counts one measurement twice; keep one of them"
            )));
        }
        Ok(())
    }

    /// The rows of leg `leg` with its reading: the rows labelled with the leg, or, if no row
    /// is, the shared rows where its reading is present (as [`super::MeasurementSet::leg_blocks`]).
    /// Each item is the row's index in [`Self::rows`] (the rows of several legs with the same
    /// index are the same measurement: a shared row), the row and the reading.
    pub fn indexed_leg_rows(&self, leg: usize) -> Vec<(usize, &ObservedRow, f64)> {
        // The label of the leg's rows: the leg, or none (the shared rows).
        let label = self.rows.iter().any(|r| r.leg == Some(leg)).then_some(leg);
        self.rows
            .iter()
            .enumerate()
            .filter(|(_, r)| r.leg == label)
            .filter_map(|(i, r)| r.readings[leg].map(|reading| (i, r, reading)))
            .collect()
    }
}

/// The instrument of `mechanism`, or an error naming the model file.
///
/// # Errors
/// [`Error::Model`] if the model has no `instrument` block.
pub fn instrument_of(mechanism: &Mechanism) -> Result<&Instrument> {
    mechanism.instrument.as_ref().ok_or_else(|| Error::Model {
        path: mechanism.model_path.clone(),
        field: "instrument".into(),
        message: "missing: target measurements need an instrument block".into(),
    })
}

/// The optional columns of the commanded platform pose (`pose.x, pose.y, …`), ignored on
/// reading.
fn commanded_columns(mechanism: &Mechanism) -> Vec<String> {
    mechanism
        .measured_names()
        .iter()
        .map(|c| format!("pose.{c}"))
        .collect()
}

/// The optional columns of a forward model: the rows' `id`, with distances the distance
/// rows' `from`, `to` and `distance`, and with measured poses the model's pose coordinates.
fn forward_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    let mut columns = Vec::new();
    if instrument.forward {
        columns.push("id".to_string());
    }
    if instrument.distances.is_some() {
        columns.extend(["from", "to", "distance"].map(String::from));
    }
    columns.extend(measured_pose_columns(mechanism, instrument));
    columns
}

/// The columns of a row's measured platform pose (the model's coordinates, unprefixed), with
/// `instrument.poses`; none without.
fn measured_pose_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    match instrument.poses {
        Some(_) => mechanism
            .measured_names()
            .iter()
            .map(|c| c.to_string())
            .collect(),
        None => Vec::new(),
    }
}

fn expected_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    rows::columns(mechanism, instrument.columns())
}

/// Reads an instrument measurement file for `mechanism`.
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Model`] if the model has no instrument;
/// [`Error::Measurement`] naming the line and column for a missing or unknown column, an
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

/// A forward model's rows must differ: the same touch entered twice (under two ids, or none)
/// counts the same measurement twice and makes the standard deviations too small.
///
/// # Errors
/// The first row that repeats an earlier one exactly (target coordinates, readings and
/// measured pose, bit for bit), naming both lines.
fn repeated_rows(path: &Path, rows: &[ObservedRow]) -> Result<()> {
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::with_capacity(rows.len());
    for (i, row) in rows.iter().enumerate() {
        // Each part tagged by its length, so that rows of different kinds never share a key.
        let mut key = vec![row.observed.len() as u64];
        key.extend(row.observed.iter().map(|v| v.to_bits()));
        key.extend(
            row.readings
                .iter()
                .map(|r| r.map_or(u64::MAX, f64::to_bits)),
        );
        key.extend(row.pose.iter().flatten().map(|v| v.to_bits()));
        if let Some(&first) = seen.get(&key) {
            let name = |r: &ObservedRow| {
                let line = r
                    .line
                    .map_or(String::from("a row"), |l| format!("line {l}"));
                match &r.id {
                    Some(id) => format!("{line} (id `{id}`)"),
                    None => line,
                }
            };
            let id = row
                .id
                .as_ref()
                .map_or(String::new(), |id| format!(" (id `{id}`)"));
            return Err(rows::fail(
                path,
                format!("line {}{id}", row.line.unwrap_or(i + 2)),
                format!(
                    "the row repeats {} exactly (the same target coordinates, readings and \
                     measured pose): a touch entered twice counts one measurement twice and \
                     makes the standard deviations too small; keep one of them",
                    name(&rows[first])
                ),
            ));
        }
        seen.insert(key, i);
    }
    Ok(())
}

/// A distance row as read, its rows still named by their ids.
struct PendingDistance {
    line: usize,
    ids: [String; 2],
    value: f64,
}

/// The cells of a distance row: two row ids and a positive distance in metres.
fn distance_row(
    path: &Path,
    line: usize,
    header: &[String],
    columns: [usize; 3],
    (from, to, distance): (&str, &str, &str),
) -> Result<PendingDistance> {
    for (column, text) in [(columns[0], from), (columns[1], to)] {
        if text.is_empty() {
            return Err(rows::fail(
                path,
                format!("line {line}, column `{}`", header[column]),
                "missing value; expected the id of a row (its `id` cell)".into(),
            ));
        }
    }
    let value = rows::number(path, line, "distance", distance, "metres")?.unwrap_or_default();
    if value <= 0.0 {
        return Err(rows::fail(
            path,
            format!("line {line}, column `distance`"),
            format!("expected a positive distance in metres, found {value}"),
        ));
    }
    Ok(PendingDistance {
        line,
        ids: [from.to_string(), to.to_string()],
        value,
    })
}

/// The distances with their rows found by id; a row without coordinates must be named by one.
fn resolve_distances(
    path: &Path,
    rows: &[ObservedRow],
    pending: Vec<PendingDistance>,
) -> Result<Vec<DistanceRow>> {
    for (i, row) in rows.iter().enumerate() {
        if let Some(id) = &row.id {
            if rows[..i].iter().any(|r| r.id.as_ref() == Some(id)) {
                return Err(rows::fail(
                    path,
                    format!("line {}, column `id`", row.line.unwrap_or(i + 2)),
                    format!("`{id}` names an earlier row too: ids must be unique"),
                ));
            }
        }
    }
    let distances = pending
        .into_iter()
        .map(|d| {
            let find = |k: usize| {
                rows.iter()
                    .position(|r| r.id.as_ref() == Some(&d.ids[k]))
                    .ok_or_else(|| {
                        rows::fail(
                            path,
                            format!("line {}, column `{}`", d.line, ["from", "to"][k]),
                            format!("no row has the id `{}`", d.ids[k]),
                        )
                    })
            };
            let pair = [find(0)?, find(1)?];
            for (k, &r) in pair.iter().enumerate() {
                if rows[r].readings.iter().any(Option::is_none) {
                    return Err(rows::fail(
                        path,
                        format!("line {}, column `{}`", d.line, ["from", "to"][k]),
                        format!(
                            "row `{}` (line {}) lacks a reading: a distance's rows need every \
                             leg's reading (their forward kinematics)",
                            d.ids[k],
                            rows[r].line.unwrap_or(r + 2)
                        ),
                    ));
                }
            }
            if pair[0] == pair[1] {
                return Err(rows::fail(
                    path,
                    format!("line {}, column `to`", d.line),
                    format!(
                        "a distance joins two different rows, not `{}` to itself",
                        d.ids[0]
                    ),
                ));
            }
            Ok(DistanceRow {
                line: Some(d.line),
                rows: pair,
                value: d.value,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some((k, first)) = repeated_pair(&distances) {
        let (d, earlier) = (&distances[k], &distances[first]);
        let id = |r: usize| rows[r].id.clone().unwrap_or_default();
        let reversed = match d.rows == earlier.rows {
            true => "",
            false => ", from and to reversed",
        };
        return Err(rows::fail(
            path,
            format!("line {}, column `from`", d.line.unwrap_or_default()),
            format!(
                "the distance between `{}` and `{}` is given already at line {}{reversed}: a \
                 distance entered twice counts one measurement twice; keep one of them (or \
                 their mean)",
                id(d.rows[0]),
                id(d.rows[1]),
                earlier.line.unwrap_or_default()
            ),
        ));
    }
    for (i, row) in rows.iter().enumerate() {
        let named = distances.iter().any(|d| d.rows.contains(&i));
        if row.observed.is_empty() && row.pose.is_none() && !named {
            return Err(rows::fail(
                path,
                format!("line {}", row.line.unwrap_or(i + 2)),
                "the row has readings but no target coordinates and no distance names it: \
                 nothing to fit"
                    .into(),
            ));
        }
    }
    Ok(distances)
}

/// The first distance (its index) that joins the same two rows as an earlier one (the earlier
/// one's index), either way round.
fn repeated_pair(distances: &[DistanceRow]) -> Option<(usize, usize)> {
    let mut seen: HashMap<[usize; 2], usize> = HashMap::with_capacity(distances.len());
    for (k, d) in distances.iter().enumerate() {
        let [a, b] = d.rows;
        if let Some(&first) = seen.get(&[a.min(b), a.max(b)]) {
            return Some((k, first));
        }
        seen.insert([a.min(b), a.max(b)], k);
    }
    None
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
