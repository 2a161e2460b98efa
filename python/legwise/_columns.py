"""Measurement columns and CSV text: numpy columns (a dict or a pandas DataFrame) to the CSV
text the library reads, and the CSV text legwise writes back to numpy columns."""

from __future__ import annotations

import csv as _csv
import io
import math
import numbers
from typing import Any, Dict, List, Mapping, Tuple

import numpy as np

from . import _native
from ._errors import LegwiseError

#: Columns read as strings (the others are numbers).
TEXT_COLUMNS = ("leg", "id", "from", "to")


class Columns(Dict[str, np.ndarray]):
    """Measurement columns (a dict of column name to 1-D numpy array, in the CSV's order),
    with the text legwise printed when it made them (:attr:`text`)."""

    text: str = ""
    """What the command prints beside the file: the description of a simulation, the report
    of a selection."""


def read_csv_text(text: str) -> Columns:
    """Measurement CSV text as columns: ``leg``, ``id``, ``from`` and ``to`` as arrays of
    strings, the others as float arrays with NaN for an empty cell (a reading not taken)."""
    rows = list(_csv.reader(io.StringIO(text)))
    header, body = rows[0], rows[1:]
    columns = Columns()
    for k, name in enumerate(header):
        cells = [row[k] for row in body]
        if name in TEXT_COLUMNS:
            columns[name] = np.array(cells, dtype=object)
        else:
            columns[name] = np.array([float(c) if c else math.nan for c in cells])
    return columns


def _refused(name: str, what: str, value: Any) -> LegwiseError:
    """The error of a column whose cells are not numbers or text: the column, what it holds
    and its first such value, on one line."""
    return LegwiseError(
        f"measurements: column `{name}` holds {what} (first: {value!r}); expected numbers in "
        "SI units, or text for `leg`, `id`, `from` and `to`"
    )


def _is_bool(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))


def _cell(name: str, value: Any) -> str:
    """A CSV cell of column `name`: text as it is, numbers at full precision (shortest round
    trip), NaN or None empty; anything else (booleans, bytes, complex numbers, dates) refused
    naming the column."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    if _is_bool(value):
        raise _refused(name, "booleans", value)
    if not isinstance(value, numbers.Real):
        raise _refused(name, f"values of type {type(value).__name__}", value)
    number = float(value)
    if math.isnan(number):
        return ""
    return repr(number)


#: What a column of each numpy kind that is neither numbers nor text holds, in words.
_REFUSED_KINDS = {
    "b": "booleans",
    "c": "complex numbers",
    "S": "bytes",
    "M": "dates",
    "m": "time spans",
    "V": "raw records",
}


def _column_cells(name: str, values: np.ndarray) -> list:
    """One column's cells for the library: a list of floats for a number column, else a list
    of text cells; a column of booleans, bytes, complex numbers or dates is refused."""
    if np.ndim(values) != 1:
        raise LegwiseError(
            f"measurements: column `{name}` has {np.ndim(values)} dimensions (shape "
            f"{np.shape(values)}); expected 1"
        )
    if values.dtype.kind in "fiu":
        return values.tolist()
    if values.dtype.kind in _REFUSED_KINDS:
        first = values[0] if len(values) else None
        raise _refused(name, f"{_REFUSED_KINDS[values.dtype.kind]} ({values.dtype})", first)
    return [_cell(name, v) for v in values.tolist()]


def _columns(measurements: Any) -> List[Tuple[str, np.ndarray]]:
    """(column name, 1-D array) pairs, in order, from a dict or a pandas DataFrame (whose
    columns are taken by position: two of one name reach the reader, which names them)."""
    if hasattr(measurements, "iloc") and hasattr(measurements, "columns"):
        return [
            (str(c), np.asarray(measurements.iloc[:, k]))
            for k, c in enumerate(measurements.columns)
        ]
    if isinstance(measurements, Mapping):
        return [(str(k), np.asarray(v)) for k, v in measurements.items()]
    raise LegwiseError(
        "measurements: expected a CSV path, a dict of column name to 1-D array, or a pandas "
        f"DataFrame; found {type(measurements).__name__}"
    )


def csv_text(measurements: Any) -> str:
    """The CSV text of columns (the layout of docs/models.md, "The measurement CSV"): float
    columns cross to the library as lists of numbers, written there at full precision."""
    columns = _columns(measurements)
    cells = [_column_cells(name, values) for name, values in columns]
    return _native.columns_csv([name for name, _ in columns], cells)
