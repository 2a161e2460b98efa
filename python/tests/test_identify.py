"""legwise.identify against the command line: the same report to the last digit (timings
aside), numpy columns as the CSV, the command line's error messages, exact recovery at zero
noise. The command line is the release binary (`cargo build --release`, or LEGWISE_BIN)."""

import csv
import json
import math
import pathlib

import numpy as np
import pytest

import legwise
from legwise._columns import csv_text

from support import MODEL, assert_same_columns, command, without_timings


@pytest.fixture(scope="module")
def measurements(tmp_path_factory):
    """A simulated 5R measurement file."""
    path = tmp_path_factory.mktemp("data") / "measurements.csv"
    status, _, err = command("simulate", "--model", MODEL, "--out", str(path))
    assert status == 0, err
    return path


def read_columns(path):
    """The CSV's columns as numpy arrays: `leg` as strings, the others as floats (NaN for an
    empty cell)."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    columns = {}
    for name in rows[0]:
        cells = [row[name] for row in rows]
        if name == "leg":
            columns[name] = np.array(cells, dtype=object)
        else:
            columns[name] = np.array([float(c) if c else math.nan for c in cells])
    return columns


def test_the_report_is_the_command_lines_json(measurements):
    status, out, err = command(
        "identify", "--model", MODEL, "--measurements", str(measurements), "--json", "-"
    )
    assert status == 0, err
    report = legwise.identify(MODEL, measurements)
    assert without_timings(report.to_dict()) == without_timings(json.loads(out))
    assert report.trusted and report.warnings == []
    assert report.text.startswith("legwise identify")


def test_numpy_columns_are_read_as_the_csv(measurements):
    from_file = legwise.identify(MODEL, measurements).to_dict()
    from_columns = legwise.identify(MODEL, read_columns(measurements)).to_dict()
    assert from_columns.pop("measurements") == legwise._native.MEMORY_NAME
    from_file.pop("measurements")
    assert without_timings(from_columns) == without_timings(from_file)


def test_bad_input_raises_the_command_lines_message(tmp_path, measurements):
    text = pathlib.Path(measurements).read_text().splitlines()
    cells = text[2].split(",")
    cells[1] = "twelve"
    text[2] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(text) + "\n")
    status, _, err = command("identify", "--model", MODEL, "--measurements", str(bad))
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.identify(MODEL, bad)
    assert err == f"legwise: {caught.value}\n"
    assert "line 3" in str(caught.value)
    assert isinstance(caught.value, ValueError)


def test_a_usage_error_is_a_legwise_error():
    with pytest.raises(legwise.LegwiseError, match="nonsense"):
        legwise.identify(MODEL, strategy="nonsense")
    with pytest.raises(legwise.LegwiseError, match="different lengths"):
        legwise.identify(MODEL, {"x": np.zeros(3), "y": np.zeros(2)})


def test_at_zero_noise_the_real_parameters_are_recovered():
    report = legwise.identify(MODEL, noise_scale=0)
    checked = 0
    for leg in report.to_dict()["results"][0]["legs"]:
        for p in leg["parameters"]:
            if not p["fixed"]:
                assert abs(p["identified"] - p["real"]) <= 1e-9, p
                checked += 1
    assert checked == 12
    names, matrix = report.covariance("leg1")
    assert matrix.shape == (len(names), len(names)) and len(names) == 6
    assert report.parameters["l1"][0] == pytest.approx(0.7507, abs=1e-9)


def test_simulate_gives_the_command_lines_csv_as_columns(tmp_path):
    status, out, err = command("simulate", "--model", MODEL, "--seed", "11", "--out", "-")
    assert status == 0, err
    columns = legwise.simulate(MODEL, seed=11)
    assert_same_columns(columns, legwise.read_csv_text(out))
    assert "seed 11" in columns.text


def test_simulated_columns_identify_to_the_real_parameters_at_zero_noise():
    real = legwise.identify(MODEL, noise_scale=0).to_dict()["results"][0]["legs"]
    report = legwise.identify(MODEL, legwise.simulate(MODEL, noise_scale=0))
    legs = report.to_dict()["results"][0]["legs"]
    for simulated, measured in zip(real, legs):
        for a, b in zip(simulated["parameters"], measured["parameters"]):
            assert abs(b["identified"] - a["real"]) <= 1e-9, (a, b)


def test_the_gil_is_released_while_legwise_computes():
    import threading
    import time

    finished = threading.Event()

    def work():
        legwise.identify(MODEL, map=0.005)  # a few hundred milliseconds of the library's
        finished.set()

    worker = threading.Thread(target=work)
    start = time.perf_counter()
    worker.start()
    ticks = 0
    while not finished.is_set():
        time.sleep(0.001)  # the main thread needs the GIL back after each sleep
        ticks += 1
    worker.join()
    elapsed = time.perf_counter() - start
    # Held by the native call, the GIL would keep this thread asleep until the call returned.
    assert elapsed > 0.05 and ticks >= 10, (elapsed, ticks)


@pytest.mark.parametrize(
    "name", ["5r.yaml", "3rpr.yaml", "delta-probe-distances.yaml", "hexapod-reflector.yaml"]
)
def test_columns_cross_as_the_text_they_were_read_from(name):
    from support import model

    text, _ = legwise._native.simulate(["--model", model(name)])
    # Every number back to the same shortest text, empty cells and the text columns included.
    assert csv_text(legwise.read_csv_text(text)) == text


def test_columns_of_unusual_types_and_values():
    text = csv_text(
        {
            "x": np.array([1e-20, 1e300, np.nan, -0.0]),
            "n": np.array([1, 2, 3, 4]),
            "leg": np.array(["a", None, np.nan, ""], dtype=object),
        }
    )
    assert text.splitlines() == [
        "x,n,leg",
        "0.00000000000000000001,1,a",
        "1" + "0" * 300 + ",2,",
        ",3,",
        "-0,4,",
    ]
    with pytest.raises(legwise.LegwiseError, match="2 dimensions"):
        csv_text({"x": np.zeros((2, 2))})


def test_each_legs_covariance_holds_the_reported_standard_deviations(measurements):
    report = legwise.identify(MODEL, measurements)
    for leg in ("leg1", "leg2"):
        names, matrix = report.covariance(leg)
        assert len(names) == 6 and np.allclose(matrix, matrix.T, rtol=0, atol=0)
        for k, name in enumerate(names):
            value, sigma = report.parameters[name]
            assert math.sqrt(matrix[k, k]) == pytest.approx(sigma, rel=1e-12)
    with pytest.raises(legwise.LegwiseError, match="no leg `leg9`"):
        report.covariance("leg9")
