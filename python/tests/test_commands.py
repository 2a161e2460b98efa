"""legwise.select, legwise.evaluate and Report.write_calibrated against the command line: the
same pose file, the same evaluation report, the same calibrated model files; the command line's
checks (never over an input, nothing written from an untrusted result)."""

import json
import pathlib

import pytest

import legwise

from support import MODEL, ROOT, assert_same_columns, command, model


@pytest.mark.parametrize(
    "name, options",
    [("5r.yaml", {"strategy": "both"}), ("delta-probe-poses.yaml", {})],
)
def test_select_gives_the_command_lines_pose_file(tmp_path, name, options):
    out = tmp_path / "poses.csv"
    flags = [w for k, v in options.items() for w in (f"--{k}", v)]
    status, stdout, err = command("select", "--model", model(name), "--out", str(out), *flags)
    assert status == 0, err
    columns = legwise.select(model(name), **options)
    assert_same_columns(columns, legwise.read_csv_text(out.read_text()))
    assert stdout.startswith(columns.text)
    readings = legwise.Mechanism(model(name)).readings
    assert all(columns[r].size > 0 and all(columns[r] != columns[r]) for r in readings)


def test_select_raises_the_command_lines_message(tmp_path):
    status, _, err = command("select", "--model", MODEL, "--out", str(tmp_path / "p"), "--grid", "0")
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.select(MODEL, grid=0)
    assert err == f"legwise: {caught.value}\n"


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A calibrated 5R (the command's `--calibrated` from the bundled example data), and a
    held-out measurement file simulated from the nominal model's real mechanism."""
    directory = tmp_path_factory.mktemp("calibrated")
    path = directory / "cal.yaml"
    data = str(ROOT / "examples" / "data" / "5r.csv")
    status, _, err = command(
        "identify", "--model", MODEL, "--measurements", data, "--calibrated", str(path)
    )
    assert status == 0, err
    held = directory / "held.csv"
    status, _, err = command(
        "simulate", "--model", MODEL, "--seed", "11", "--poses", "random", "--out", str(held)
    )
    assert status == 0, err
    return path, held


def test_evaluate_gives_the_command_lines_report(calibrated):
    path, held = calibrated
    status, out, err = command(
        "evaluate", "--model", str(path), "--against", MODEL, "--measurements", str(held),
        "--json", "-",
    )
    assert status == 0, err
    expected = json.loads(out)
    from_file = legwise.evaluate(path, held, against=MODEL)
    assert from_file == expected
    assert from_file.trusted and from_file.text.strip() == err.strip()
    nominal = legwise.Mechanism(MODEL)
    from_columns = legwise.evaluate(path, legwise.read_csv_text(held.read_text()), against=nominal)
    for report in (from_columns, from_columns["against"]):
        assert report.pop("measurements") == legwise._native.MEMORY_NAME
    for report in (expected, expected["against"]):
        report.pop("measurements")
    assert from_columns == expected
    # The calibration helps on data it was not fitted to.
    after, before = expected["position_error_m"]["rms"], expected["against"]["position_error_m"]["rms"]
    assert after < before / 10


def test_evaluate_raises_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,A1,A2\n0.1,0.2,0.3,\n")
    status, _, err = command("evaluate", "--model", MODEL, "--measurements", str(bad))
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.evaluate(MODEL, bad)
    assert err == f"legwise: {caught.value}\n"


def test_write_calibrated_writes_the_command_lines_files(tmp_path, calibrated):
    by_command, _ = calibrated
    data = ROOT / "examples" / "data" / "5r.csv"
    report = legwise.identify(MODEL, data)
    written = report.write_calibrated(tmp_path / "mine.yaml")
    assert "mine.yaml" in written and "mine.urdf" in written
    mine = (tmp_path / "mine.yaml").read_text().replace("mine.urdf", "cal.urdf")
    assert mine == by_command.read_text()
    assert (tmp_path / "mine.urdf").read_text() == by_command.with_suffix(".urdf").read_text()
    # The calibrated model loads, and holds the identified values.
    loaded = legwise.Mechanism(tmp_path / "mine.yaml")
    for name, (value, _) in report.parameters.items():
        assert loaded.parameters[name].nominal == pytest.approx(value, rel=1e-12, abs=1e-15)


def test_write_calibrated_never_overwrites_an_input_nor_writes_an_untrusted_result(tmp_path):
    report = legwise.identify(MODEL, ROOT / "examples" / "data" / "5r.csv")
    with pytest.raises(legwise.LegwiseError, match="model file"):
        report.write_calibrated(MODEL)
    untrusted = legwise.identify(MODEL, ROOT / "tests" / "data" / "huge_reading.csv")
    assert not untrusted.trusted
    with pytest.raises(legwise.LegwiseError, match="must not be trusted"):
        untrusted.write_calibrated(tmp_path / "cal.yaml")
    assert list(tmp_path.iterdir()) == []


def test_sets_gives_the_command_lines_table(tmp_path):
    """An imported Klipper printer's table, from a path and from columns: the command line's
    JSON; Klipper's six factors give the printer behind the touches (radius 175.15 mm)."""
    printer = tmp_path / "printer"
    cfg = str(ROOT / "tests" / "data" / "klipper" / "printer.cfg")
    status, _, err = command("printer", "import", "--klipper", cfg, "--out", str(printer))
    assert status == 0, err
    model_path, probe = str(printer / "printer.yaml"), str(printer / "probe.csv")
    out = tmp_path / "sets.json"
    status, stdout, err = command(
        "sets", "--model", model_path, "--measurements", probe, "--json", str(out)
    )
    assert status == 0, err
    table = legwise.sets(model_path, probe)
    assert table.sets == json.loads(out.read_text())
    assert stdout.startswith(table.text)
    radius, sigma = table.estimates("klipper-6")["radius"]
    assert abs(radius - 0.17515) < 1e-7 and sigma > 0
    columns = legwise.read_csv_text(pathlib.Path(probe).read_text())
    assert legwise.sets(model_path, dict(columns)).sets[1]["factors"] == table["klipper-6"]["factors"]
    with pytest.raises(legwise.LegwiseError) as caught:
        table["klipper-7"]
    assert "expected one of model, klipper-6, klipper-9" in str(caught.value)
