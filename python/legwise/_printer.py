"""Delta printers: a firmware's files imported as a legwise model and probe CSV, and a
calibrated model exported as the firmware's values, as ``legwise printer import`` and
``legwise printer export`` do (docs/printers.md)."""

from __future__ import annotations

import os
from typing import Any, NamedTuple, Optional, Union

from . import _native
from ._commands import Model, _arguments
from ._errors import LegwiseError
from ._mechanism import Mechanism
from ._words import path

Path = Union[str, "os.PathLike[str]"]


class ImportedPrinter(NamedTuple):
    """What :func:`import_printer` wrote: the model, the probe CSV's path, and the import's
    report (the conventions it used and the values it read)."""

    model: Mechanism
    probes: str
    report: str


class PrinterExport(NamedTuple):
    """What :func:`export_printer` gives: the firmware's lines (Klipper's SAVE_CONFIG block,
    ``M665``/``M666``/``M92`` lines) and the report (the values, what the export loses)."""

    values: str
    summary: str


_FIRMWARES = ("klipper", "rrf", "marlin")


def _firmware(firmware: str) -> str:
    if firmware not in _FIRMWARES:
        raise LegwiseError(
            f"firmware: expected one of {', '.join(_FIRMWARES)}, found {firmware!r}"
        )
    return firmware


def import_printer(
    firmware: str,
    config: Path,
    out: Path,
    overrides: Optional[Path] = None,
    probes: Optional[Path] = None,
    **options: Any,
) -> ImportedPrinter:
    """Imports a delta printer from its firmware's files: ``firmware`` is ``"klipper"`` (``config``
    a printer.cfg, SAVE_CONFIG block included), ``"rrf"`` (``config`` a config.g, ``overrides``
    its config-override.g) or ``"marlin"`` (``config`` an M503 report); ``probes`` the probe log
    (RepRapFirmware, Marlin). Writes ``out``/printer.yaml, printer.urdf and probe.csv.
    ``options`` are the command's: ``probe_noise=5e-6``, ``distance_noise``, ``rod_prior=0``,
    ``gain_prior=0`` (0 holds the factor: the firmware's own factors)."""
    arguments = ["--" + _firmware(firmware), path("config", config), "--out", path("out", out)]
    if overrides is not None:
        arguments += ["--override", path("overrides", overrides)]
    if probes is not None:
        arguments += ["--probes", path("probes", probes)]
    report = _native.printer_import(arguments + _arguments(options))
    directory = os.fspath(out)
    return ImportedPrinter(
        Mechanism(os.path.join(directory, "printer.yaml")),
        os.path.join(directory, "probe.csv"),
        report,
    )


def export_printer(
    calibrated: Model,
    firmware: str,
    firmware_config: Optional[Path] = None,
    bed_radius: Optional[float] = None,
) -> PrinterExport:
    """The calibrated model ``calibrated`` (``legwise identify --calibrated`` on an imported
    printer) as ``firmware``'s values (``"klipper"``, ``"rrf"``, ``"marlin"``): the values whose
    kinematics come closest to the model over the bed, and what they lose. With
    ``firmware_config`` (the file the printer was imported from) the calibrated gains are written
    as its step settings (``rotation_distance``, ``M92``)."""
    arguments = ["--" + _firmware(firmware), "--calibrated", path("calibrated", calibrated)]
    if firmware_config is not None:
        arguments += ["--firmware-config", path("firmware_config", firmware_config)]
    arguments += _arguments({"bed_radius": bed_radius})
    values, summary = _native.printer_export(arguments)
    return PrinterExport(values, summary)
