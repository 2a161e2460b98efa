"""legwise from Python: the kinematic identification (calibration) of parallel mechanisms.

The same library as the ``legwise`` command line, one import away::

    import legwise
    report = legwise.identify("models/5r.yaml", "measurements.csv")
    report.to_dict()          # the JSON report of `legwise identify --json` (docs/report.md)
    report.parameters["l1"]   # (identified value, standard deviation)

Measurements are a CSV path, or columns named as in the CSV (a dict of column name to 1-D
array, or a pandas DataFrame): numbers in SI units, ``leg`` as strings, a missing reading as
NaN. Errors are :class:`LegwiseError` (a ``ValueError``) with legwise's own message.
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _native

LegwiseError = _native.LegwiseError
"""Bad input, bad usage or a failed identification (a ``ValueError``); the message is the one
the command line prints after ``legwise:``."""

__all__ = ["identify", "simulate", "read_csv_text", "Report", "LegwiseError"]

Columns = Mapping[str, Any]
Measurements = Union[str, "os.PathLike[str]", Columns, Any]


class Report:
    """The result of :func:`identify`: the JSON report and its views."""

    def __init__(self, report: Dict[str, Any], text: str, warnings: List[str]):
        self._report = report
        self.text = text
        """The terminal report, as ``legwise identify`` prints it."""
        self.warnings = list(warnings)
        """Why the result must not be trusted, one line each (empty when it may be)."""

    @property
    def trusted(self) -> bool:
        """False where ``legwise identify`` would exit 3 (the result must not be trusted)."""
        return not self.warnings

    def to_dict(self) -> Dict[str, Any]:
        """The JSON report of ``legwise identify --json`` (docs/report.md), as a new dict."""
        return json.loads(json.dumps(self._report))

    def _results(self) -> List[Dict[str, Any]]:
        return self._report["results"]

    @property
    def parameters(self) -> Dict[str, Tuple[float, Optional[float]]]:
        """Each parameter's identified value and standard deviation (None where none is
        reported), by name, of the first strategy's result: every leg's, then the
        instrument's."""
        result = self._results()[0]
        values: Dict[str, Tuple[float, Optional[float]]] = {}
        for leg in result["legs"]:
            for p in leg["parameters"]:
                values[p["name"]] = (p["identified"], p["std"])
        instrument = result.get("instrument")
        if instrument:
            for p in instrument["parameters"]:
                values[p["name"]] = (p["identified"], p["std"])
        return values

    def covariance(self, leg: str) -> Tuple[List[str], np.ndarray]:
        """The leg's identified parameters and their covariance matrix (first strategy)."""
        for entry in self._results()[0]["legs"]:
            if entry["name"] == leg:
                names = list(entry.get("covariance_parameters") or [])
                matrix = np.array(entry.get("covariance") or [], dtype=float)
                return names, matrix.reshape(len(names), len(names))
        raise LegwiseError(f"no leg `{leg}` in the report")


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


def _csv_text(measurements: Any) -> str:
    """The CSV text of columns (the layout of docs/models.md, "The measurement CSV")."""
    columns = _columns(measurements)
    lengths = {name: len(np.atleast_1d(values)) for name, values in columns.items()}
    for name, values in columns.items():
        if np.ndim(values) != 1:
            raise LegwiseError(
                f"measurements: column `{name}` has {np.ndim(values)} dimensions; expected 1"
            )
    if len(set(lengths.values())) > 1:
        raise LegwiseError(f"measurements: columns of different lengths {lengths}")
    names = list(columns)
    rows = max(lengths.values(), default=0)
    lines = [",".join(names)]
    for i in range(rows):
        lines.append(",".join(_cell(columns[name][i]) for name in names))
    return "\n".join(lines) + "\n"


def _arguments(options: Mapping[str, Any]) -> List[str]:
    """Keyword options as the command's arguments: ``noise_scale=0`` is ``--noise-scale 0``,
    ``drop_outliers=True`` is ``--drop-outliers`` (False or None: not given)."""
    words: List[str] = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            words.append(flag)
        else:
            words.extend([flag, str(value)])
    return words


def identify(
    model: Union[str, "os.PathLike[str]"],
    measurements: Optional[Measurements] = None,
    strategy: Optional[str] = None,
    solver: Optional[str] = None,
    **options: Any,
) -> Report:
    """Identifies the parameters of the mechanism of ``model`` (a model file) from
    ``measurements`` (a CSV path, or columns as a dict or a DataFrame), or from the model's
    simulation when None.

    ``strategy`` (``dc``, ``traditional``, ``both``) and ``solver`` (``lm``, ``gn``) default to
    the command's; ``options`` are the other options of ``legwise identify`` by name:
    ``weights="none"``, ``robust="cauchy"``, ``drop_outliers=True``, ``map=0.01``,
    ``noise_scale=0``, ``seed=3``, ``poses="random"``… The GIL is released while legwise
    computes.

    Raises :class:`LegwiseError` with legwise's message for bad input or usage.
    """
    arguments = ["--model", os.fspath(model)]
    if strategy is not None:
        arguments += ["--strategy", strategy]
    if solver is not None:
        arguments += ["--solver", solver]
    arguments += _arguments(options)
    csv = None
    if isinstance(measurements, (str, os.PathLike)):
        arguments += ["--measurements", os.fspath(measurements)]
    elif measurements is not None:
        csv = _csv_text(measurements)
    report, text, warnings = _native.identify(arguments, csv)
    return Report(json.loads(report), text, warnings)


#: Columns read as strings (the others are numbers).
TEXT_COLUMNS = ("leg", "id", "from", "to")


def read_csv_text(text: str) -> Dict[str, np.ndarray]:
    """Measurement CSV text as columns: ``leg``, ``id``, ``from`` and ``to`` as arrays of
    strings, the others as float arrays with NaN for an empty cell (a reading not taken)."""
    import csv
    import io

    rows = list(csv.reader(io.StringIO(text)))
    header, body = rows[0], rows[1:]
    columns: Dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        cells = [row[k] for row in body]
        if name in TEXT_COLUMNS:
            columns[name] = np.array(cells, dtype=object)
        else:
            columns[name] = np.array([float(c) if c else math.nan for c in cells])
    return columns


def simulate(model: Union[str, "os.PathLike[str]"], **options: Any) -> Dict[str, np.ndarray]:
    """The model's simulated measurements, as ``legwise simulate`` writes them, as columns
    (:func:`read_csv_text`): ``options`` are the command's (``seed=11``, ``noise_scale=0``,
    ``poses="random"``, ``poses_per_leg=20``…). The result can be passed to :func:`identify`
    as its measurements."""
    text, _source = _native.simulate(["--model", os.fspath(model)] + _arguments(options))
    return read_csv_text(text)
