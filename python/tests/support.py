"""What the tests share: the repository's paths, the command line they compare with (the
release binary, `cargo build --release`, or LEGWISE_BIN), and comparisons."""

import os
import pathlib
import subprocess

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODEL = str(ROOT / "models" / "5r.yaml")
BINARY = os.environ.get("LEGWISE_BIN", str(ROOT / "target" / "release" / "legwise"))


def model(name):
    """The bundled model file `name` (`5r.yaml`, …) as a path string."""
    return str(ROOT / "models" / name)


def command(*arguments, cwd=None):
    """The command line's run: (exit status, standard output, standard error)."""
    run = subprocess.run([BINARY, *arguments], capture_output=True, text=True, cwd=cwd)
    return run.returncode, run.stdout, run.stderr


def without_timings(value):
    """The report without its wall-clock figures (`seconds`), the only values that differ
    between two runs."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def assert_same_columns(columns, expected):
    """Two dicts of columns hold the same names in the same order and the same cells (text
    cells equal, numbers bit for bit, NaN where NaN)."""
    assert list(columns) == list(expected)
    for name in columns:
        if columns[name].dtype == object:
            assert list(columns[name]) == list(expected[name]), name
        else:
            np.testing.assert_array_equal(columns[name], expected[name])
