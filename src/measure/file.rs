//! The measurement CSV: a header row, then one row per measured pose.
//!
//! Columns: `leg` (optional; the leg whose identification set the row belongs to, empty for a
//! pose shared by all legs), one column per measured coordinate (`x`, `y`, `yaw` …, metres and
//! radians) and one per actuated joint, named after its URDF joint, holding the raw reading
//! (empty when not read). Errors name the file, the line and the column.

use std::io::{BufRead, Read, Write};
use std::path::Path;

use rayon::prelude::*;

use super::line_endings::Lines;
use super::{rows, MeasuredPose, MeasurementSet};
use crate::error::{Error, Result};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// Column layout of a measurement file for a mechanism.
fn expected_columns(mechanism: &Mechanism) -> Vec<String> {
    let measured = mechanism
        .measured_names()
        .into_iter()
        .map(|s| s.to_string());
    rows::columns(mechanism, measured)
}

/// Reads a measurement file for `mechanism`, streaming (the file's text is never held whole).
///
/// # Errors
/// [`Error::Io`] if unreadable; [`Error::Measurement`] naming the line and column for a missing
/// or unknown column, an unknown leg, a non-numeric or non-finite cell, a missing coordinate,
/// text that is not UTF-8, or a file without rows.
pub fn read(path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    let file = std::fs::File::open(path).map_err(rows::io_error(path))?;
    read_from(file, path, mechanism)
}

/// Reads a measurement file for `mechanism` from any reader (a file, standard input); `name`
/// is the file's name in messages (e.g. `<stdin>`).
///
/// # Errors
/// [`Error::Io`] if the reader fails; otherwise as [`parse`].
pub fn read_from(reader: impl Read, name: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    parse_rows(reader, name, mechanism, true)
}

/// Parses measurement CSV text; `path` is only used in messages.
///
/// # Errors
/// As [`read`].
pub fn parse(text: &str, path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    parse_rows(text.as_bytes(), path, mechanism, true)
}

/// Reads a pose file in the measurement layout for drawing: as [`read`], but a labelled row's
/// reading may be empty (the poses `legwise select` writes, before they are measured).
///
/// # Errors
/// As [`read`], except for empty readings.
pub fn read_poses(path: &Path, mechanism: &Mechanism) -> Result<MeasurementSet> {
    let file = std::fs::File::open(path).map_err(rows::io_error(path))?;
    parse_rows(file, path, mechanism, false)
}

/// Records read before their rows are parsed (in parallel, while the next batch is read).
const BATCH_RECORDS: usize = 16_384;

/// Records a parallel task parses.
const RECORDS_PER_TASK: usize = 1_024;

/// The rows of a measurement CSV read from `source` (buffered by the CSV reader): records are
/// read in batches into reused buffers, and each batch's cells are parsed in parallel (rayon)
/// while the next batch is read. Cells are read as bytes and trimmed in place; the rows'
/// readings go flat into the set (no allocation per row). The first error in file order is
/// reported, as a row-by-row reading would.
fn parse_rows(
    source: impl Read,
    path: &Path,
    mechanism: &Mechanism,
    require_readings: bool,
) -> Result<MeasurementSet> {
    let expected = expected_columns(mechanism);
    // The cells are trimmed here (of Unicode whitespace, as `str::trim`): the CSV reader's
    // trimming of the fields builds a new record for every row.
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::Headers)
        .flexible(false)
        .from_reader(Lines::new(std::io::BufReader::new(source)));
    let header: Vec<String> = match reader.headers() {
        Ok(header) => header.iter().map(str::to_string).collect(),
        Err(e) => return Err(csv_error(path, &e, "header".into())),
    };
    if header.iter().all(String::is_empty) {
        return Err(rows::fail(
            path,
            "header".into(),
            format!("empty file; expected the columns {}", expected.join(", ")),
        ));
    }
    rows::check_header(path, &header, &expected, &[], &expected.join(", "))?;
    let index = |name: &str| header.iter().position(|h| h == name);
    let layout = Layout {
        path,
        mechanism,
        header: &header,
        leg_column: index("leg"),
        coordinate_columns: mechanism
            .measured
            .iter()
            .map(|&c| (c, index(COORDINATES[c]).unwrap_or_default()))
            .collect(),
        reading_columns: mechanism
            .actuated_names()
            .iter()
            .map(|name| index(name).unwrap_or_default())
            .collect(),
        require_readings,
    };
    let mut set = MeasurementSet::new(Some(path.to_path_buf()), mechanism.legs.len());
    let mut parsing = Batch::default();
    let mut reading = Batch::default();
    let mut read_error = reading.fill(&mut reader);
    while reading.count > 0 || read_error.is_some() {
        std::mem::swap(&mut parsing, &mut reading);
        let failed = read_error.take();
        let mut parsed = Vec::new();
        rayon::in_place_scope(|scope| {
            scope.spawn(|_| parsed = layout.parse(&parsing.records[..parsing.count]));
            // The next batch is read meanwhile (none after a failed read).
            reading.count = 0;
            if failed.is_none() {
                read_error = reading.fill(&mut reader);
            }
        });
        for chunk in parsed {
            let (poses, readings) = chunk?;
            for (k, pose) in poses.into_iter().enumerate() {
                set.push(pose, &readings[k * set.legs()..(k + 1) * set.legs()]);
            }
        }
        if let Some(e) = failed {
            let line = e
                .position()
                .map_or(0, |p| reader.get_ref().line_at(p.byte()));
            return Err(csv_error(path, &e, format!("line {line}")));
        }
    }
    if set.is_empty() {
        return Err(rows::no_rows(path));
    }
    set.shrink_to_fit();
    Ok(set)
}

/// A batch of records read and not yet parsed (the buffers are reused from batch to batch).
#[derive(Default)]
struct Batch {
    records: Vec<csv::ByteRecord>,
    count: usize,
}

impl Batch {
    /// Reads up to [`BATCH_RECORDS`] records; the reader's error, if it failed (the records
    /// before it are kept).
    fn fill(&mut self, reader: &mut csv::Reader<Lines<impl BufRead>>) -> Option<csv::Error> {
        self.count = 0;
        while self.count < BATCH_RECORDS {
            if self.records.len() == self.count {
                self.records.push(csv::ByteRecord::new());
            }
            let record = &mut self.records[self.count];
            match reader.read_byte_record(record) {
                Ok(true) => {
                    // The line as an editor numbers it (see `Lines`).
                    if let Some(mut position) = record.position().cloned() {
                        position.set_line(reader.get_ref().line_at(position.byte()));
                        record.set_position(Some(position));
                    }
                    self.count += 1;
                }
                Ok(false) => return None,
                Err(e) => return Some(e),
            }
        }
        None
    }
}

/// The parsed rows of one task: the poses and their readings, flat.
type ParsedRows = Result<(Vec<MeasuredPose>, Vec<Option<f64>>)>;

/// Where the columns of a measurement file are, and what its rows must hold.
struct Layout<'l> {
    path: &'l Path,
    mechanism: &'l Mechanism,
    header: &'l [String],
    leg_column: Option<usize>,
    coordinate_columns: Vec<(usize, usize)>,
    reading_columns: Vec<usize>,
    require_readings: bool,
}

impl Layout<'_> {
    /// The rows of `records`, in parallel tasks of [`RECORDS_PER_TASK`] records, in order.
    fn parse(&self, records: &[csv::ByteRecord]) -> Vec<ParsedRows> {
        records
            .par_chunks(RECORDS_PER_TASK)
            .map(|chunk| {
                let mut poses = Vec::with_capacity(chunk.len());
                let mut readings = Vec::with_capacity(chunk.len() * self.reading_columns.len());
                for record in chunk {
                    if let Some(pose) = self.row(record, &mut readings)? {
                        poses.push(pose);
                    }
                }
                Ok((poses, readings))
            })
            .collect()
    }

    /// One record's pose (its readings appended to `readings`), `None` for a blank row.
    fn row(
        &self,
        record: &csv::ByteRecord,
        readings: &mut Vec<Option<f64>>,
    ) -> Result<Option<MeasuredPose>> {
        let (path, header) = (self.path, self.header);
        let fail = |location: String, message: String| rows::fail(path, location, message);
        let line = record.position().map_or(0, |p| p.line() as usize);
        let blank = |bytes: &[u8]| std::str::from_utf8(bytes).is_ok_and(|t| t.trim().is_empty());
        if record.iter().all(blank) {
            return Ok(None);
        }
        let cell = |column: usize| -> Result<&str> {
            let bytes = record.get(column).unwrap_or_default();
            std::str::from_utf8(bytes).map(str::trim).map_err(|_| {
                fail(
                    format!("line {line}, column `{}`", header[column]),
                    format!(
                        "the cell is not UTF-8 text: `{}`",
                        String::from_utf8_lossy(bytes)
                    ),
                )
            })
        };
        let number = |column: usize, unit: &str| {
            rows::number(path, line, &header[column], cell(column)?, unit)
        };
        let leg_cell = match self.leg_column {
            Some(column) => cell(column)?,
            None => "",
        };
        let leg = rows::leg_of(path, line, self.mechanism, leg_cell)?;
        let mut pose = self.mechanism.home_pose;
        for &(coordinate, column) in &self.coordinate_columns {
            let unit = if coordinate < 3 { "metres" } else { "radians" };
            pose[coordinate] = number(column, unit)?.ok_or_else(|| {
                fail(
                    format!("line {line}, column `{}`", header[column]),
                    format!("missing value; expected a number in {unit}"),
                )
            })?;
        }
        let start = readings.len();
        for &column in &self.reading_columns {
            readings.push(number(column, "SI units (radians or metres)")?);
        }
        if self.require_readings {
            rows::require_leg_reading(path, line, self.mechanism, leg, &readings[start..])?;
        }
        Ok(Some(MeasuredPose {
            line: Some(line),
            leg,
            pose,
        }))
    }
}

/// A CSV reader's error at `location`: the reader's I/O failure as [`Error::Io`], anything
/// else as [`Error::Measurement`].
fn csv_error(path: &Path, error: &csv::Error, location: String) -> Error {
    match error.kind() {
        csv::ErrorKind::Io(io) => Error::Io {
            path: path.to_path_buf(),
            error: std::io::Error::new(io.kind(), io.to_string()),
        },
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => rows::fail(
            path,
            location,
            format!("expected {expected_len} fields, found {len}"),
        ),
        _ => rows::fail(path, location, error.to_string()),
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
    let fail = rows::io_error(path);
    let file = std::fs::File::create(path).map_err(&fail)?;
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

/// A row's first cells: its leg's name (empty for a shared row), then its pose's measured
/// coordinates.
pub(crate) fn leg_and_pose_cells(mechanism: &Mechanism, pose: &MeasuredPose) -> Vec<String> {
    let mut cells = vec![pose
        .leg
        .map_or(String::new(), |l| mechanism.legs[l].name.clone())];
    cells.extend(
        mechanism
            .measured
            .iter()
            .map(|&c| format!("{}", pose.pose[c])),
    );
    cells
}

/// The CSV text of a measurement set.
pub fn to_csv(mechanism: &Mechanism, set: &MeasurementSet) -> String {
    let lines = set.rows().map(|(pose, readings)| {
        let mut cells = leg_and_pose_cells(mechanism, pose);
        cells.extend(readings.iter().map(rows::reading_cell));
        cells
    });
    rows::csv_text(&expected_columns(mechanism), lines)
}
