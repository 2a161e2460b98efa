//! The measurement CSV: a header row, then one row per measured pose.
//!
//! Columns: `leg` (optional; the leg whose identification set the row belongs to, empty for a
//! pose shared by all legs), one column per measured coordinate (`x`, `y`, `yaw` …, metres and
//! radians) and one per actuated joint, named after its URDF joint, holding the raw reading
//! (empty when not read). Errors name the file, the line and the column.

use std::io::{Read, Write};
use std::path::Path;

use super::{rows, MeasuredPose, MeasurementSet};
use crate::error::{Error, Result};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// Column layout of a measurement file for a mechanism.
fn expected_columns(mechanism: &Mechanism) -> Vec<String> {
    let mut columns = vec!["leg".to_string()];
    columns.extend(mechanism.measured_names().iter().map(|s| s.to_string()));
    columns.extend(mechanism.actuated_names().iter().map(|s| s.to_string()));
    columns
}

/// Reads a measurement file for `mechanism`.
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Measurement`] naming the line and column for a missing
/// or unknown column, an unknown leg, a non-numeric or non-finite cell, a missing coordinate, or
/// a file without rows.
pub fn read(path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    let file = std::fs::File::open(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    read_from(file, path, mechanism)
}

/// Reads a measurement file for `mechanism` from any reader (a file, standard input); `name`
/// is the file's name in messages (e.g. `<stdin>`).
///
/// # Errors
/// [`Error::Io`] if the reader fails or the text is not UTF-8; otherwise as [`parse`].
pub fn read_from(
    mut reader: impl Read,
    name: &Path,
    mechanism: &Mechanism,
) -> Result<MeasurementSet> {
    let mut text = String::new();
    reader
        .read_to_string(&mut text)
        .map_err(|error| Error::Io {
            path: name.to_path_buf(),
            error,
        })?;
    parse(&text, name, mechanism)
}

/// Parses measurement CSV text; `path` is only used in messages.
///
/// # Errors
/// As [`read`].
pub fn parse(text: &str, path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    parse_rows(text, path, mechanism, true)
}

/// Reads a pose file in the measurement layout for drawing: as [`read`], but a labelled row's
/// reading may be empty (the poses `legwise select` writes, before they are measured).
///
/// # Errors
/// As [`read`], except for empty readings.
pub fn read_poses(path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    let text = std::fs::read_to_string(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_rows(&text, path, mechanism, false)
}

fn parse_rows(
    text: &str,
    path: &Path,
    mechanism: &Mechanism,
    require_readings: bool,
) -> Result<MeasurementSet> {
    let fail = |location: String, message: String| Error::Measurement {
        path: path.to_path_buf(),
        location,
        message,
    };
    let expected = expected_columns(mechanism);
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| fail("header".into(), e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    if header.iter().all(String::is_empty) {
        return Err(fail(
            "header".into(),
            format!("empty file; expected the columns {}", expected.join(", ")),
        ));
    }
    rows::check_header(path, &header, &expected, &[], &expected.join(", "))?;
    let index = |name: &str| header.iter().position(|h| h == name);
    let leg_column = index("leg");
    let coordinate_columns: Vec<(usize, usize)> = mechanism
        .measured
        .iter()
        .map(|&c| (c, index(COORDINATES[c]).unwrap_or_default()))
        .collect();
    let reading_columns: Vec<usize> = mechanism
        .actuated_names()
        .iter()
        .map(|name| index(name).unwrap_or_default())
        .collect();
    // One pose per line at most: no regrowth of a large vector; one record buffer for all rows.
    let mut poses = Vec::with_capacity(text.bytes().filter(|&b| b == b'\n').count());
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                return Err(fail(format!("line {line}"), csv_message(&e)));
            }
        }
        let line = record.position().map_or(0, |p| p.line() as usize);
        if record.iter().all(str::is_empty) {
            continue;
        }
        let cell = |column: usize| record.get(column).unwrap_or("");
        let number = |column: usize, unit: &str| {
            rows::number(path, line, &header[column], cell(column), unit)
        };
        let leg = rows::leg_of(path, line, mechanism, leg_column.map_or("", cell))?;
        let mut pose = mechanism.home_pose;
        for &(coordinate, column) in &coordinate_columns {
            let unit = if coordinate < 3 { "metres" } else { "radians" };
            pose[coordinate] = number(column, unit)?.ok_or_else(|| {
                fail(
                    format!("line {line}, column `{}`", header[column]),
                    format!("missing value; expected a number in {unit}"),
                )
            })?;
        }
        let mut readings = Vec::with_capacity(reading_columns.len());
        for &column in &reading_columns {
            readings.push(number(column, "SI units (radians or metres)")?);
        }
        if require_readings {
            rows::require_leg_reading(path, line, mechanism, leg, &readings)?;
        }
        poses.push(MeasuredPose {
            line: Some(line),
            leg,
            pose,
            readings,
        });
    }
    if poses.is_empty() {
        return Err(rows::no_rows(path));
    }
    Ok(MeasurementSet {
        source: Some(path.to_path_buf()),
        poses,
    })
}

fn csv_message(error: &csv::Error) -> String {
    match error.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("expected {expected_len} fields, found {len}")
        }
        _ => error.to_string(),
    }
}

/// Writes measurements in the layout [`read`] expects (exact round trip of every value).
///
/// The file is created or truncated and written in place; the command line instead writes a
/// temporary file and renames it, so that an interrupted run never leaves a cut file.
///
/// # Errors
/// [`Error::Io`] if the file cannot be written.
pub fn write(path: &Path, mechanism: &Mechanism, set: &MeasurementSet) -> Result<()> {
    let fail = |error| Error::Io {
        path: path.to_path_buf(),
        error,
    };
    let file = std::fs::File::create(path).map_err(fail)?;
    write_to(file, mechanism, set).map_err(fail)
}

/// Writes measurements in the layout [`read`] expects to any writer (a file, standard output).
///
/// # Errors
/// The writer's error.
pub fn write_to(
    mut writer: impl Write,
    mechanism: &Mechanism,
    set: &MeasurementSet,
) -> std::io::Result<()> {
    writer.write_all(to_csv(mechanism, set).as_bytes())?;
    writer.flush()
}

/// The CSV text of a measurement set.
pub fn to_csv(mechanism: &Mechanism, set: &MeasurementSet) -> String {
    let mut text = expected_columns(mechanism).join(",");
    text.push('\n');
    for pose in &set.poses {
        let mut cells = vec![pose
            .leg
            .map_or(String::new(), |l| mechanism.legs[l].name.clone())];
        cells.extend(
            mechanism
                .measured
                .iter()
                .map(|&c| format!("{}", pose.pose[c])),
        );
        cells.extend(
            pose.readings
                .iter()
                .map(|r| r.map_or(String::new(), |v| format!("{v}"))),
        );
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    text
}
