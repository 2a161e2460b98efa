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
from typing import Any, Dict, List, Mapping, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _native

LegwiseError = _native.LegwiseError
"""Bad input, bad usage or a failed identification (a ``ValueError``); the message is the one
the command line prints after ``legwise:``."""

__all__ = [
    "identify",
    "simulate",
    "select",
    "evaluate",
    "read_csv_text",
    "Mechanism",
    "Parameter",
    "Report",
    "Evaluation",
    "Columns",
    "LegwiseError",
]

Measurements = Union[str, "os.PathLike[str]", Mapping[str, Any], Any]
Model = Union[str, "os.PathLike[str]"]
"""A model file's path, or a :class:`Mechanism`."""


class Report:
    """The result of :func:`identify`: the JSON report and its views."""

    def __init__(self, native: Any):
        self._native = native
        self._parsed: Optional[Dict[str, Any]] = None
        self.text: str = native.text
        """The terminal report, as ``legwise identify`` prints it."""
        self.warnings: List[str] = list(native.trust_issues)
        """Why the result must not be trusted, one line each (empty when it may be)."""

    @property
    def _report(self) -> Dict[str, Any]:
        """The JSON report, parsed when first needed."""
        if self._parsed is None:
            self._parsed = json.loads(self._native.json)
        return self._parsed

    @property
    def trusted(self) -> bool:
        """False where ``legwise identify`` would exit 3 (the result must not be trusted)."""
        return not self.warnings

    def to_dict(self) -> Dict[str, Any]:
        """The JSON report of ``legwise identify --json`` (docs/report.md), as a new dict."""
        return json.loads(self._native.json)

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

    def write_calibrated(self, path: Union[str, "os.PathLike[str]"]) -> str:
        """Writes the calibrated model as ``legwise identify --calibrated path`` does: the
        model file at ``path`` and its URDF beside it (extension ``.urdf``), each written to a
        temporary file renamed into place, never over the model, its URDF or the measurement
        file. Returns what was written, in words.

        Raises :class:`LegwiseError` when the result must not be trusted (the reasons are in
        the message), or when a path would overwrite an input."""
        return self._native.write_calibrated(os.fspath(path))


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
    model: Model,
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
    return Report(_native.identify(arguments, csv))


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
    import csv
    import io

    rows = list(csv.reader(io.StringIO(text)))
    header, body = rows[0], rows[1:]
    columns = Columns()
    for k, name in enumerate(header):
        cells = [row[k] for row in body]
        if name in TEXT_COLUMNS:
            columns[name] = np.array(cells, dtype=object)
        else:
            columns[name] = np.array([float(c) if c else math.nan for c in cells])
    return columns


def simulate(model: Model, **options: Any) -> Columns:
    """The model's simulated measurements, as ``legwise simulate`` writes them, as columns
    (:func:`read_csv_text`; ``.text`` describes the simulation): ``options`` are the command's
    (``seed=11``, ``noise_scale=0``, ``poses="random"``, ``poses_per_leg=20``…). The result
    can be passed to :func:`identify` as its measurements."""
    csv, source = _native.simulate(["--model", os.fspath(model)] + _arguments(options))
    columns = read_csv_text(csv)
    columns.text = source
    return columns


def select(model: Model, **options: Any) -> Columns:
    """The poses to measure, as ``legwise select`` writes them (measurement CSV layout, the
    readings and what the instrument reports empty: NaN), as columns; ``.text`` is the
    command's report of the selection. ``options`` are the command's: ``strategy`` (``"dc"``
    per-leg sets, ``"traditional"`` one shared set, ``"both"``), ``grid`` (metres),
    ``poses_per_leg``, ``criterion`` (``"d"``, ``"a"``, ``"e"``)."""
    csv, text = _native.select(["--model", os.fspath(model)] + _arguments(options))
    columns = read_csv_text(csv)
    columns.text = text
    return columns


class Evaluation(Dict[str, Any]):
    """The evaluation report of :func:`evaluate` (a dict: the JSON of ``legwise evaluate
    --json``, docs/report.md), with the terminal report and the verdict."""

    def __init__(self, report: Dict[str, Any], text: str, warnings: List[str]):
        super().__init__(report)
        self.text = text
        """The terminal report, as ``legwise evaluate`` prints it."""
        self.warnings = list(warnings)
        """Why the evaluation must not be trusted, one line each (empty when it may be)."""

    @property
    def trusted(self) -> bool:
        """False where ``legwise evaluate`` would exit 3."""
        return not self.warnings


def evaluate(
    model: Model,
    measurements: Measurements,
    against: Optional[Model] = None,
) -> Evaluation:
    """How well ``model`` explains ``measurements`` (a CSV path, or columns as a dict or a
    DataFrame), typically held out of the fit: the report of ``legwise evaluate --json``
    (pose errors by forward kinematics from the readings, each leg's reading residuals), with
    ``against`` (another model, typically the nominal one) side by side."""
    arguments = ["--model", os.fspath(model)]
    if against is not None:
        arguments += ["--against", os.fspath(against)]
    csv = None
    if isinstance(measurements, (str, os.PathLike)):
        arguments += ["--measurements", os.fspath(measurements)]
    else:
        csv = _csv_text(measurements)
    report, text, warnings = _native.evaluate(arguments, csv)
    return Evaluation(json.loads(report), text, warnings)


class Parameter(NamedTuple):
    """A parameter of a model: its nominal value (SI units), whether it is identified or held
    at its nominal value, its unit (``m``, ``rad``, ``-``), its owner (a leg's name, or
    ``"instrument"``), and its real value in the mechanism the model's simulation block draws
    with its own seed (what :func:`simulate` without ``seed`` simulates; None without a
    simulation block)."""

    nominal: float
    identified: bool
    unit: str
    owner: str
    real: Optional[float]


class Mechanism(os.PathLike):  # type: ignore[type-arg]
    """A model file (docs/models.md), loaded and checked as every command loads it: what it
    holds, and the functions of the module on it. It is a path-like object: wherever a model
    path is expected, a Mechanism can be given. The file is read again by each call (as by
    each command), so its path is kept as given."""

    def __init__(self, path: Union[str, "os.PathLike[str]"]):
        self.path: str = os.fspath(path)
        """The model file, as given."""
        description = json.loads(_native.describe(self.path))
        self.description: Dict[str, Any] = description
        """Everything below as one dict (JSON types)."""
        self.name: str = description["name"]
        """The model's name."""
        self.legs: List[str] = [leg["name"] for leg in description["legs"]]
        """The legs' names, in the model's order."""
        self.readings: List[str] = [leg["actuated"] for leg in description["legs"]]
        """Each leg's actuated joint: the reading columns of a measurement file."""
        self.measured: List[str] = list(description["measured"])
        """The platform pose coordinates a measurement row holds (a model without an
        instrument, or a forward instrument's measured poses)."""
        self.instrument: Optional[Dict[str, Any]] = description["instrument"]
        """None, or the instrument: ``forward`` (seen through the forward kinematics),
        ``columns`` (the target coordinates a row holds), ``parameters``."""
        self.warnings: List[str] = list(description["warnings"])
        """Implausible values of the model, one line each (a command would exit 3)."""
        self.parameters: Dict[str, Parameter] = {}
        """Every parameter by name: each leg's, then the instrument's."""
        for leg in description["legs"]:
            for p in leg["parameters"]:
                self.parameters[p["name"]] = Parameter(
                    p["nominal"], p["identified"], p["unit"], leg["name"], p["real"]
                )
        for p in (self.instrument or {}).get("parameters", []):
            self.parameters[p["name"]] = Parameter(
                p["nominal"], p["identified"], p["unit"], "instrument", p["real"]
            )

    def __fspath__(self) -> str:
        return self.path

    def __repr__(self) -> str:
        return f"legwise.Mechanism({self.path!r})"

    @property
    def identified(self) -> List[str]:
        """The names of the identified parameters, in the model's order."""
        return [name for name, p in self.parameters.items() if p.identified]

    def identify(self, measurements: Optional[Measurements] = None, **options: Any) -> Report:
        """:func:`identify` on this model."""
        return identify(self, measurements, **options)

    def simulate(self, **options: Any) -> Columns:
        """:func:`simulate` on this model."""
        return simulate(self, **options)

    def select(self, **options: Any) -> Columns:
        """:func:`select` on this model."""
        return select(self, **options)

    def evaluate(self, measurements: Measurements, against: Optional[Model] = None) -> Evaluation:
        """:func:`evaluate` on this model."""
        return evaluate(self, measurements, against)
