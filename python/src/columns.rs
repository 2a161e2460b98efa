//! Measurement columns (numbers or text) as CSV text, for the library's reader: the Python
//! module's numpy columns cross the boundary as lists, not as text made cell by cell in Python.

use pyo3::prelude::*;

/// One column's cells: numbers (a float column, NaN for a reading not taken) or text.
#[derive(Debug, FromPyObject)]
pub(crate) enum Column {
    /// Numbers, written at full precision (the shortest text that reads back to the same
    /// number); NaN as an empty cell.
    Numbers(Vec<f64>),
    /// Text cells, written as they are.
    Texts(Vec<String>),
}

impl Column {
    /// The number of cells.
    fn len(&self) -> usize {
        match self {
            Column::Numbers(values) => values.len(),
            Column::Texts(values) => values.len(),
        }
    }

    /// Appends cell `row` to `line`.
    fn push_cell(&self, row: usize, line: &mut String) {
        use std::fmt::Write;
        match self {
            Column::Numbers(values) if values[row].is_nan() => {}
            Column::Numbers(values) => {
                let _ = write!(line, "{}", values[row]);
            }
            Column::Texts(values) => line.push_str(&values[row]),
        }
    }
}

/// The CSV text of the columns `columns` named `names` (a header, then one line per row).
///
/// # Errors
/// A message when the names and the columns differ in number, or the columns in length.
pub(crate) fn csv_text(names: &[String], columns: &[Column]) -> Result<String, String> {
    if names.len() != columns.len() {
        return Err(format!(
            "measurements: {} column names for {} columns",
            names.len(),
            columns.len()
        ));
    }
    let rows = columns.first().map_or(0, Column::len);
    if let Some((name, column)) = names.iter().zip(columns).find(|(_, c)| c.len() != rows) {
        return Err(format!(
            "measurements: columns of different lengths (`{}`: {rows}, `{name}`: {})",
            names[0],
            column.len()
        ));
    }
    let mut text = names.join(",");
    text.push('\n');
    for row in 0..rows {
        for (k, column) in columns.iter().enumerate() {
            if k > 0 {
                text.push(',');
            }
            column.push_cell(row, &mut text);
        }
        text.push('\n');
    }
    Ok(text)
}
