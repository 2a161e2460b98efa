"""The native part of the legwise module (PyO3): strings in, strings out."""

from typing import List, Optional, Tuple

MEMORY_NAME: str

class LegwiseError(ValueError): ...

class Identification:
    """The outputs of an identification kept in memory."""

    @property
    def json(self) -> str:
        """The JSON report, as `legwise identify --json` writes it."""
    @property
    def text(self) -> str:
        """The terminal report."""
    @property
    def trust_issues(self) -> List[str]:
        """Why the result must not be trusted, one line each."""
    def write_calibrated(self, path: str) -> str:
        """Writes the calibrated model to `path` and its URDF beside it, as `legwise identify
        --calibrated path` does: what was written, in words."""

def identify(arguments: List[str], csv: Optional[str] = None) -> Identification:
    """`legwise identify` with the command's arguments (after `identify`) on the CSV text `csv`
    if given."""

def simulate(arguments: List[str]) -> Tuple[str, str]:
    """`legwise simulate` with the command's arguments (after `simulate`, without `--out`):
    (measurement CSV, description of the simulation)."""

def select(arguments: List[str]) -> Tuple[str, str]:
    """`legwise select` with the command's arguments (after `select`, without `--out`): (pose
    CSV, report of the selection)."""

def evaluate(arguments: List[str], csv: Optional[str] = None) -> Tuple[str, str, List[str]]:
    """`legwise evaluate` with the command's arguments (after `evaluate`) on the CSV text `csv`
    if given: (JSON evaluation, terminal report, reasons not to trust it)."""

def describe(path: str) -> str:
    """The model file at `path`, loaded and checked, described as JSON."""

def sets(arguments: List[str], csv: Optional[str] = None) -> Tuple[str, str]:
    """`legwise sets` with the command's arguments (after `sets`) on the CSV text `csv` if
    given: (JSON table, terminal table)."""

def printer_import(arguments: List[str]) -> str:
    """`legwise printer import` with the command's arguments (after `printer import`): writes
    the model files into `--out`'s directory; what the command prints."""

def printer_export(arguments: List[str]) -> Tuple[str, str]:
    """`legwise printer export` with the command's arguments (after `printer export`, without
    `--out`): (the firmware's lines, the command's report)."""
