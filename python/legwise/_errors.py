"""The module's error."""

from . import _native

LegwiseError = _native.LegwiseError
"""Bad input, bad usage or a failed identification (a ``ValueError``); the message is the one
the command line prints after ``legwise:``."""
