"""Python values as the command's words: options' values and file paths, anything else
refused as a :class:`LegwiseError` naming the option or argument and the value."""

from __future__ import annotations

import numbers
import os
from typing import Any

import numpy as np

from ._errors import LegwiseError


def word(option: str, value: Any) -> str:
    """An option's value as the command's word: a string or a path as it is, a number as
    Python writes it; anything else refused naming the option and the value."""
    if isinstance(value, str):
        return value
    if isinstance(value, os.PathLike):
        return os.fsdecode(value)
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        return str(value)
    raise LegwiseError(
        f"option `{option}`: expected a string or a number; found {type(value).__name__} "
        f"{value!r}"
    )


def path(what: str, value: Any) -> str:
    """A file's path (`model`, `measurements`, `against`) as text; anything else refused
    naming the argument and the value."""
    if isinstance(value, (str, os.PathLike)):
        return os.fsdecode(value)
    raise LegwiseError(
        f"{what}: expected a file's path (a str or a path-like object such as "
        f"legwise.Mechanism); found {type(value).__name__} {value!r}"
    )
