"""The native part of the legwise module (PyO3): strings in, strings out."""

from typing import List, Optional, Tuple

MEMORY_NAME: str

class LegwiseError(ValueError): ...

def identify(arguments: List[str], csv: Optional[str] = None) -> Tuple[str, str, List[str]]:
    """`legwise identify` with the command's arguments (after `identify`) on the CSV text `csv`
    if given: (JSON report, terminal report, reasons not to trust the result)."""

def simulate(arguments: List[str]) -> Tuple[str, str]:
    """`legwise simulate` with the command's arguments (after `simulate`, without `--out`):
    (measurement CSV, description of the simulation)."""
