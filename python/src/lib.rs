//! `legwise._native`: the Python module's native part. Strings cross the boundary (the command
//! line's arguments, CSV text, the JSON reports); the Python package (`legwise/`) turns numpy arrays and
//! dictionaries into them and back. The work runs without the GIL, and no panic reaches
//! Python: every failure is a `legwise.LegwiseError` carrying the command line's message.

mod columns;
mod model_description;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    legwise,
    LegwiseError,
    PyValueError,
    "Bad input, bad usage or a failed identification: the message is legwise's."
);

/// Runs `work` without the GIL, a panic caught: its value, or a `LegwiseError` with legwise's
/// message (the whole chain of an error, as the command line prints it).
fn guarded<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(work))) {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(error)) => Err(LegwiseError::new_err(format!("{error:#}"))),
        Err(_) => Err(LegwiseError::new_err(PANIC)),
    }
}

/// The message of a panic caught before it reaches Python.
const PANIC: &str = "legwise failed inside (a panic): this is a bug of legwise, not of the input";

/// The outputs of an identification kept in memory: the JSON report, the terminal report, the
/// reasons not to trust it, and the calibrated model to write.
#[pyclass(frozen, module = "legwise._native")]
struct Identification {
    outputs: legwise::cli::IdentifyOutputs,
}

#[pymethods]
impl Identification {
    /// The JSON report, as `legwise identify --json` writes it.
    #[getter]
    fn json(&self) -> &str {
        &self.outputs.json
    }

    /// The terminal report.
    #[getter]
    fn text(&self) -> &str {
        &self.outputs.text
    }

    /// Why the result must not be trusted, one line each (empty when it may be).
    #[getter]
    fn trust_issues(&self) -> Vec<String> {
        self.outputs.trust_issues.clone()
    }

    /// Writes the calibrated model to `path` and the URDF beside it, as `legwise identify
    /// --calibrated path` does: what it wrote, in words.
    fn write_calibrated(&self, py: Python<'_>, path: PathBuf) -> PyResult<String> {
        guarded(py, || self.outputs.write_calibrated(&path))
    }
}

/// `legwise identify` with the command's arguments `arguments` (after `identify`), on the CSV
/// text `csv` if given.
#[pyfunction]
#[pyo3(signature = (arguments, csv=None))]
fn identify(
    py: Python<'_>,
    arguments: Vec<String>,
    csv: Option<String>,
) -> PyResult<Identification> {
    let outputs = guarded(py, || {
        legwise::cli::identify_in_memory(&arguments, csv.as_deref())
    })?;
    Ok(Identification { outputs })
}

/// `legwise simulate` with the command's arguments `arguments` (after `simulate`, without
/// `--out`): `(csv, source)`, the measurement CSV and the description of the simulation.
#[pyfunction]
fn simulate(py: Python<'_>, arguments: Vec<String>) -> PyResult<(String, String)> {
    guarded(py, || legwise::cli::simulate_in_memory(&arguments))
}

/// `legwise select` with the command's arguments `arguments` (after `select`, without `--out`):
/// `(csv, text)`, the pose file and the report of the selection.
#[pyfunction]
fn select(py: Python<'_>, arguments: Vec<String>) -> PyResult<(String, String)> {
    guarded(py, || legwise::cli::select_in_memory(&arguments))
}

/// `legwise evaluate` with the command's arguments `arguments` (after `evaluate`), on the CSV
/// text `csv` if given: `(json, text, trust_issues)`.
#[pyfunction]
#[pyo3(signature = (arguments, csv=None))]
fn evaluate(
    py: Python<'_>,
    arguments: Vec<String>,
    csv: Option<String>,
) -> PyResult<(String, String, Vec<String>)> {
    let outputs = guarded(py, || {
        legwise::cli::evaluate_in_memory(&arguments, csv.as_deref())
    })?;
    Ok((outputs.json, outputs.text, outputs.trust_issues))
}

/// `legwise sets` with the command's arguments `arguments` (after `sets`), on the CSV text
/// `csv` if given: `(json, text)`.
#[pyfunction]
#[pyo3(signature = (arguments, csv=None))]
fn sets(py: Python<'_>, arguments: Vec<String>, csv: Option<String>) -> PyResult<(String, String)> {
    guarded(py, || {
        legwise::cli::sets_in_memory(&arguments, csv.as_deref())
    })
}

/// `legwise printer import` with the command's arguments `arguments` (after `printer import`):
/// writes the model, its URDF and the probe CSV into `--out`'s directory; what the command
/// prints.
#[pyfunction]
fn printer_import(py: Python<'_>, arguments: Vec<String>) -> PyResult<String> {
    guarded(py, || legwise::cli::printer_import_in_memory(&arguments))
}

/// `legwise printer export` with the command's arguments `arguments` (after `printer export`,
/// without `--out`): `(values, summary)`, the firmware's lines and what the command reports.
#[pyfunction]
fn printer_export(py: Python<'_>, arguments: Vec<String>) -> PyResult<(String, String)> {
    guarded(py, || {
        legwise::cli::printer_export_in_memory(&arguments).map(|o| (o.values, o.summary))
    })
}

/// The CSV text of the columns `columns` named `names` (numbers at full precision, NaN as an
/// empty cell; text as it is), for `identify` and `evaluate`.
#[pyfunction]
fn columns_csv(names: Vec<String>, columns: Vec<columns::Column>) -> PyResult<String> {
    columns::csv_text(&names, &columns).map_err(LegwiseError::new_err)
}

/// The model file at `path`, loaded and checked as every command loads it, described as JSON
/// (name, legs, parameters with their nominal values, instrument, warnings).
#[pyfunction]
fn describe(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    guarded(py, || {
        let mechanism = legwise::Mechanism::load(&path)?;
        Ok(model_description::description(&mechanism).to_string())
    })
}

/// The module.
#[pymodule]
fn _native(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add_function(wrap_pyfunction!(identify, module)?)?;
    module.add_function(wrap_pyfunction!(simulate, module)?)?;
    module.add_function(wrap_pyfunction!(select, module)?)?;
    module.add_function(wrap_pyfunction!(evaluate, module)?)?;
    module.add_function(wrap_pyfunction!(sets, module)?)?;
    module.add_function(wrap_pyfunction!(describe, module)?)?;
    module.add_function(wrap_pyfunction!(printer_import, module)?)?;
    module.add_function(wrap_pyfunction!(printer_export, module)?)?;
    module.add_function(wrap_pyfunction!(columns_csv, module)?)?;
    module.add_class::<Identification>()?;
    module.add("LegwiseError", module.py().get_type::<LegwiseError>())?;
    module.add("MEMORY_NAME", legwise::cli::MEMORY_NAME)?;
    Ok(())
}
