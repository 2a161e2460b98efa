//! `legwise._native`: the Python module's native part. Strings cross the boundary (the command
//! line's arguments, CSV text, the JSON report); `legwise/__init__.py` turns numpy arrays and
//! dictionaries into them and back. The identification runs without the GIL, and no panic
//! reaches Python: every failure is a `legwise.LegwiseError` carrying the command line's
//! message.

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    legwise,
    LegwiseError,
    PyValueError,
    "Bad input, bad usage or a failed identification: the message is legwise's."
);

/// `legwise identify` with the command's arguments `arguments` (after `identify`), on the CSV
/// text `csv` if given: `(json, text, trust_issues)`.
#[pyfunction]
#[pyo3(signature = (arguments, csv=None))]
fn identify(
    py: Python<'_>,
    arguments: Vec<String>,
    csv: Option<String>,
) -> PyResult<(String, String, Vec<String>)> {
    let outcome = py.detach(|| {
        catch_unwind(AssertUnwindSafe(|| {
            legwise::cli::identify_in_memory(&arguments, csv.as_deref())
        }))
    });
    match outcome {
        Ok(Ok(outputs)) => Ok((outputs.json, outputs.text, outputs.trust_issues)),
        Ok(Err(error)) => Err(LegwiseError::new_err(format!("{error:#}"))),
        Err(_) => Err(LegwiseError::new_err(PANIC)),
    }
}

/// `legwise simulate` with the command's arguments `arguments` (after `simulate`, without
/// `--out`): `(csv, source)`, the measurement CSV and the description of the simulation.
#[pyfunction]
fn simulate(py: Python<'_>, arguments: Vec<String>) -> PyResult<(String, String)> {
    let outcome = py.detach(|| {
        catch_unwind(AssertUnwindSafe(|| {
            legwise::cli::simulate_in_memory(&arguments)
        }))
    });
    match outcome {
        Ok(Ok(outputs)) => Ok(outputs),
        Ok(Err(error)) => Err(LegwiseError::new_err(format!("{error:#}"))),
        Err(_) => Err(LegwiseError::new_err(PANIC)),
    }
}

/// The message of a panic caught before it reaches Python.
const PANIC: &str = "legwise failed inside (a panic): this is a bug of legwise, not of the input";

/// The module.
#[pymodule]
fn _native(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add_function(wrap_pyfunction!(identify, module)?)?;
    module.add_function(wrap_pyfunction!(simulate, module)?)?;
    module.add("LegwiseError", module.py().get_type::<LegwiseError>())?;
    module.add("MEMORY_NAME", legwise::cli::MEMORY_NAME)?;
    Ok(())
}
