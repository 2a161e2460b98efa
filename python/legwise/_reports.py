"""What the identification and the evaluation return: the JSON reports and their views."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from ._errors import LegwiseError
from ._words import path as path_text

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
        return self._native.write_calibrated(path_text("write_calibrated", path))


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


class FactorSets:
    """The result of :func:`sets`: one entry per set (the model's own, ``"model"``, first), as
    ``legwise sets --json`` writes it."""

    def __init__(self, table: List[Dict[str, Any]], text: str):
        self.sets: List[Dict[str, Any]] = table
        """Each set: ``name``, ``rows``, ``degrees_of_freedom``, ``rms``, ``leave_one_out``,
        ``scale``, ``information`` (AIC), ``information_corrected`` (AICc, the recommendation's score), ``rank``, ``predicted`` and ``factors`` (each ``name``, ``unit``, ``nominal``, ``estimate``,
        ``sigma``)."""
        self.text: str = text
        """The table as ``legwise sets`` prints it."""

    def __getitem__(self, name: str) -> Dict[str, Any]:
        for entry in self.sets:
            if entry["name"] == name:
                return entry
        raise LegwiseError(
            f"no factor set is named `{name}`; expected one of "
            + ", ".join(e["name"] for e in self.sets)
        )

    def estimates(self, name: str) -> Dict[str, Tuple[float, Optional[float]]]:
        """Set ``name``'s factors: name to (estimate, σ), SI units."""
        return {f["name"]: (f["estimate"], f["sigma"]) for f in self[name]["factors"]}
