"""The Python boundary's errors: every wrong option, argument or column is a LegwiseError on
one line naming the option or the column and the value (docs/python.md, "Errors")."""

import datetime

import numpy as np
import pytest

import legwise

from support import MODEL, command, model


def raised(call, *arguments, **options):
    """The LegwiseError `call` raises, checked to be one line."""
    with pytest.raises(legwise.LegwiseError) as caught:
        call(*arguments, **options)
    message = str(caught.value)
    assert "\n" not in message, message
    return message


def test_an_option_of_the_wrong_type_names_the_option_and_the_value():
    message = raised(legwise.identify, MODEL, solver=[1])
    assert message == "option `solver`: expected a string or a number; found list [1]"
    message = raised(legwise.simulate, MODEL, seed={"a": 1})
    assert message.startswith("option `seed`: ") and "{'a': 1}" in message


def test_a_number_where_a_word_is_expected_is_the_command_lines_one_line_usage_error():
    message = raised(legwise.identify, MODEL, solver=1)
    status, _, err = command("identify", "--model", MODEL, "--solver", "1")
    assert status == 2
    assert err == f"legwise: {message}\n"
    assert "'1'" in message and "--solver" in message and "lm, gn" in message
    assert "try '--help'" not in message


@pytest.mark.parametrize(
    "options, named",
    [({"bogus": 3}, "--bogus"), ({"strategy": "nonsense"}, "nonsense"), ({"seed": "x"}, "'x'")],
)
def test_usage_errors_are_one_line(options, named):
    message = raised(legwise.identify, MODEL, **options)
    assert named in message and message.endswith("see `legwise identify --help`"), message


def test_a_model_that_is_not_a_path_is_named():
    assert raised(legwise.identify, 1).startswith("model: expected a file's path")
    assert raised(legwise.Mechanism, 1.5).startswith("Mechanism: expected a file's path")
    assert raised(legwise.evaluate, MODEL, "m.csv", against=3).startswith("against: ")


@pytest.fixture(scope="module")
def columns():
    return legwise.simulate(MODEL, seed=11)


@pytest.mark.parametrize(
    "cells, what",
    [
        (lambda n: np.ones(n, dtype=bool), "booleans (bool)"),
        (lambda n: np.ones(n, dtype=complex), "complex numbers (complex128)"),
        (lambda n: np.array([b"0.5"] * n), "bytes (|S3)"),
        (lambda n: np.array(["2026-01-01"] * n, dtype="datetime64[D]"), "dates (datetime64[D])"),
        (lambda n: np.array([True] * n, dtype=object), "booleans"),
        (lambda n: np.array([1 + 2j] * n, dtype=object), "values of type complex"),
        (lambda n: np.array([b"1"] * n, dtype=object), "values of type bytes"),
        (lambda n: np.array([datetime.date(2026, 1, 1)] * n, dtype=object), "values of type date"),
    ],
)
def test_a_column_of_neither_numbers_nor_text_names_the_column(columns, cells, what):
    bad = dict(columns)
    bad["A1"] = cells(len(columns["A1"]))
    message = raised(legwise.identify, MODEL, bad)
    assert message.startswith(f"measurements: column `A1` holds {what}"), message
    assert "(first: " in message


def test_a_column_of_booleans_is_not_read_as_readings_of_one(columns):
    """Issue 39: True was read as 1.0."""
    bad = dict(columns)
    bad["A2"] = columns["A2"] > 0
    with pytest.raises(legwise.LegwiseError, match="column `A2` holds booleans"):
        legwise.identify(MODEL, bad)


def test_a_two_dimensional_column_names_its_shape():
    message = raised(legwise.identify, MODEL, {"x": np.zeros((2, 2))})
    assert message == "measurements: column `x` has 2 dimensions (shape (2, 2)); expected 1"


def test_a_data_frame_with_two_columns_of_one_name_is_named_as_in_a_csv(columns, tmp_path):
    pandas = pytest.importorskip("pandas")
    frame = pandas.DataFrame(dict(columns))
    frame.insert(2, "x", frame["x"], allow_duplicates=True)
    message = raised(legwise.identify, MODEL, frame)
    path = tmp_path / "twice.csv"
    frame.to_csv(path, index=False)
    status, _, err = command("identify", "--model", MODEL, "--measurements", str(path))
    assert status == 2
    expected = err.removeprefix("legwise: ").strip().replace(str(path), legwise._native.MEMORY_NAME)
    assert message == expected
    assert "`x`" in message


def test_a_missing_distance_names_the_distance_column():
    name = model("delta-probe-distances.yaml")
    data = legwise.simulate(name)
    rows = np.flatnonzero(data["to"] != "")
    data["distance"][rows[0]] = np.nan
    message = raised(legwise.identify, name, data)
    line = rows[0] + 2  # the header is line 1
    assert message.startswith(
        f"{legwise._native.MEMORY_NAME}: line {line}, column `distance`: missing distance"
    ), message
