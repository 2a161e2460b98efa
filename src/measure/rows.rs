//! What the two measurement CSV readers (platform poses, `file`; an instrument's target
//! coordinates, `observations`) share: I/O errors, the columns, the header check, number cells,
//! the `leg` cell, the rule that a leg's row carries that leg's reading, and the CSV text. Every
//! error names the file, the line and the column.

use std::path::Path;

use crate::error::{Error, Result};
use crate::model::Mechanism;

/// A measurement error at `location` (`header`, `line 7`, ``line 7, column `x` ``).
pub(super) fn fail(path: &Path, location: String, message: String) -> Error {
    Error::Measurement {
        path: path.to_path_buf(),
        location,
        message,
    }
}

/// An I/O error on the file at `path` (named `path` in messages), for `map_err`.
pub(super) fn io_error(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |error| Error::Io {
        path: path.to_path_buf(),
        error,
    }
}

/// The columns of a measurement file: the optional `leg`, then `middle`, then one per actuated
/// joint with its reading.
pub(super) fn columns(
    mechanism: &Mechanism,
    middle: impl IntoIterator<Item = String>,
) -> Vec<String> {
    let mut columns = vec!["leg".to_string()];
    columns.extend(middle);
    columns.extend(mechanism.actuated_names().iter().map(|s| s.to_string()));
    columns
}

/// CSV text: the `header` line, then one line per row of cells.
pub(super) fn csv_text(header: &[String], rows: impl Iterator<Item = Vec<String>>) -> String {
    let mut text = header.join(",");
    text.push('\n');
    for cells in rows {
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    text
}

/// A reading's cell: the value, empty when not read.
pub(super) fn reading_cell(reading: &Option<f64>) -> String {
    reading.map_or(String::new(), |v| format!("{v}"))
}

/// Checks a header: no column twice, every column among `expected` or `optional`, and every
/// column of `expected` but its first (the optional `leg`) present. `listing` is how the
/// messages name the expected columns.
pub(super) fn check_header(
    path: &Path,
    header: &[String],
    expected: &[String],
    optional: &[String],
    listing: &str,
) -> Result<()> {
    for (i, column) in header.iter().enumerate() {
        if header[..i].contains(column) {
            return Err(fail(
                path,
                "header".into(),
                format!("column `{column}` appears twice"),
            ));
        }
        if !expected.contains(column) && !optional.contains(column) {
            return Err(fail(
                path,
                "header".into(),
                format!("unknown column `{column}`; expected the columns {listing}"),
            ));
        }
    }
    for column in expected.iter().skip(1) {
        if !header.contains(column) {
            return Err(fail(
                path,
                "header".into(),
                format!("missing column `{column}`; expected the columns {listing}"),
            ));
        }
    }
    Ok(())
}

/// The number in a cell (`None` if the cell is empty), or an error naming the line, the
/// column and the expected `unit`.
pub(super) fn number(
    path: &Path,
    line: usize,
    column: &str,
    text: &str,
    unit: &str,
) -> Result<Option<f64>> {
    if text.is_empty() {
        return Ok(None);
    }
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(fail(
            path,
            format!("line {line}, column `{column}`"),
            format!("expected a finite number in {unit}, found `{text}`"),
        )),
    }
}

/// The leg a row belongs to (`None` for an empty `leg` cell), or an error naming the legs.
pub(super) fn leg_of(
    path: &Path,
    line: usize,
    mechanism: &Mechanism,
    cell: &str,
) -> Result<Option<usize>> {
    if cell.is_empty() {
        return Ok(None);
    }
    mechanism.leg_index(cell).map(Some).ok_or_else(|| {
        let names: Vec<&str> = mechanism.legs.iter().map(|l| l.name.as_str()).collect();
        fail(
            path,
            format!("line {line}, column `leg`"),
            format!(
                "unknown leg `{cell}`; expected one of {} or empty",
                names.join(", ")
            ),
        )
    })
}

/// The error of a file with a header and no measurement row.
pub(super) fn no_rows(path: &Path) -> Error {
    fail(
        path,
        "line 2".into(),
        "no measurement rows after the header".into(),
    )
}

/// A row labelled with a leg must carry that leg's reading.
pub(super) fn require_leg_reading(
    path: &Path,
    line: usize,
    mechanism: &Mechanism,
    leg: Option<usize>,
    readings: &[Option<f64>],
) -> Result<()> {
    match leg {
        Some(l) if readings[l].is_none() => Err(fail(
            path,
            format!("line {line}, column `{}`", mechanism.actuated_names()[l]),
            format!(
                "the row belongs to leg `{}` but its reading is empty",
                mechanism.legs[l].name
            ),
        )),
        _ => Ok(()),
    }
}
