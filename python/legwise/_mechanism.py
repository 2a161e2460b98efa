"""A model file loaded and described: ``legwise.Mechanism``."""

from __future__ import annotations

import json
import os
from typing import Any, Dict, List, NamedTuple, Optional, Union

from . import _native
from ._columns import Columns
from ._commands import Measurements, Model, evaluate, identify, select, simulate
from ._reports import Evaluation, Report
from ._words import path as path_text

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
        self.path: str = path_text("Mechanism", path)
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
