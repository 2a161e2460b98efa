"""The commands: ``identify``, ``simulate``, ``select``, ``evaluate`` and ``sets``, as the command line
runs them (its arguments, parser, checks and readers, in the library), their outputs returned."""

from __future__ import annotations

import json
import os
from typing import Any, List, Mapping, Optional, Union

import numpy as np

from . import _native
from ._columns import Columns, csv_text, read_csv_text
from ._reports import Evaluation, FactorSets, Report
from ._words import path, word

Measurements = Union[str, "os.PathLike[str]", Mapping[str, Any], Any]
"""A CSV path, or columns: a dict of column name to 1-D array, or a pandas DataFrame."""
Model = Union[str, "os.PathLike[str]"]
"""A model file's path, or a :class:`legwise.Mechanism`."""


def _arguments(options: Mapping[str, Any]) -> List[str]:
    """Keyword options as the command's arguments: ``noise_scale=0`` is ``--noise-scale 0``,
    ``drop_outliers=True`` is ``--drop-outliers`` (False or None: not given)."""
    words: List[str] = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is None or value is False or value is np.False_:
            continue
        if value is True or value is np.True_:
            words.append(flag)
        else:
            words.extend([flag, word(key, value)])
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
    arguments = ["--model", path("model", model)]
    arguments += _arguments({"strategy": strategy, "solver": solver, **options})
    csv = None
    if isinstance(measurements, (str, os.PathLike)):
        arguments += ["--measurements", path("measurements", measurements)]
    elif measurements is not None:
        csv = csv_text(measurements)
    return Report(_native.identify(arguments, csv))


def simulate(model: Model, **options: Any) -> Columns:
    """The model's simulated measurements, as ``legwise simulate`` writes them, as columns
    (:func:`read_csv_text`; ``.text`` describes the simulation): ``options`` are the command's
    (``seed=11``, ``noise_scale=0``, ``poses="random"``, ``poses_per_leg=20``…). The result
    can be passed to :func:`identify` as its measurements."""
    csv, source = _native.simulate(["--model", path("model", model)] + _arguments(options))
    columns = read_csv_text(csv)
    columns.text = source
    return columns


def select(model: Model, **options: Any) -> Columns:
    """The poses to measure, as ``legwise select`` writes them (measurement CSV layout, the
    readings and what the instrument reports empty: NaN), as columns; ``.text`` is the
    command's report of the selection. ``options`` are the command's: ``strategy`` (``"dc"``
    per-leg sets, ``"traditional"`` one shared set, ``"both"``), ``grid`` (metres),
    ``poses_per_leg``, ``criterion`` (``"d"``, ``"a"``, ``"e"``)."""
    csv, text = _native.select(["--model", path("model", model)] + _arguments(options))
    columns = read_csv_text(csv)
    columns.text = text
    return columns


def evaluate(
    model: Model,
    measurements: Measurements,
    against: Optional[Model] = None,
) -> Evaluation:
    """How well ``model`` explains ``measurements`` (a CSV path, or columns as a dict or a
    DataFrame), typically held out of the fit: the report of ``legwise evaluate --json``
    (pose errors by forward kinematics from the readings, each leg's reading residuals), with
    ``against`` (another model, typically the nominal one) side by side."""
    arguments = ["--model", path("model", model)]
    if against is not None:
        arguments += ["--against", path("against", against)]
    csv = None
    if isinstance(measurements, (str, os.PathLike)):
        arguments += ["--measurements", path("measurements", measurements)]
    else:
        csv = csv_text(measurements)
    report, text, warnings = _native.evaluate(arguments, csv)
    return Evaluation(json.loads(report), text, warnings)


def sets(model: Model, measurements: Optional[Measurements] = None) -> FactorSets:
    """The model's own parameters and each of its factor sets (``factor_sets:``, e.g. a delta
    printer's firmware factors) fitted on the same ``measurements`` (a CSV path or columns; the
    model's simulated experiment if None): the table of ``legwise sets --json``."""
    arguments = ["--model", path("model", model)]
    csv = None
    if measurements is not None:
        if isinstance(measurements, (str, os.PathLike)):
            arguments += ["--measurements", path("measurements", measurements)]
        else:
            csv = csv_text(measurements)
    table, text = _native.sets(arguments, csv)
    return FactorSets(json.loads(table), text)
