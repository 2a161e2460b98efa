"""Measurement columns and CSV text: numpy columns (a dict or a pandas DataFrame) to the CSV
text the library reads, and the CSV text legwise writes back to numpy columns."""

from __future__ import annotations

import csv as _csv
import io
import math
from typing import Any, Dict, Mapping

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


def _cell(value: Any) -> str:
    """A CSV cell: numbers at full precision (shortest round trip), NaN or None empty."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    number = float(value)
    if math.isnan(number):
        return ""
    return repr(number)


def _columns(measurements: Any) -> Dict[str, np.ndarray]:
    """A dict of column name to 1-D array from a dict or a pandas DataFrame."""
    if hasattr(measurements, "to_dict") and hasattr(measurements, "columns"):
        return {str(c): np.asarray(measurements[c]) for c in measurements.columns}
    if isinstance(measurements, Mapping):
        return {str(k): np.asarray(v) for k, v in measurements.items()}
    raise LegwiseError(
        "measurements: expected a CSV path, a dict of column name to 1-D array, or a pandas "
        f"DataFrame; found {type(measurements).__name__}"
    )


def csv_text(measurements: Any) -> str:
    """The CSV text of columns (the layout of docs/models.md, "The measurement CSV"): float
    columns cross to the library as lists of numbers, written there at full precision."""
    columns = _columns(measurements)
    for name, values in columns.items():
        if np.ndim(values) != 1:
            raise LegwiseError(
                f"measurements: column `{name}` has {np.ndim(values)} dimensions; expected 1"
            )
    cells = [
        values.tolist() if values.dtype.kind in "fiu" else [_cell(v) for v in values.tolist()]
        for values in columns.values()
    ]
    return _native.columns_csv(list(columns), cells)
