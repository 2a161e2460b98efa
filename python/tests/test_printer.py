"""legwise.import_printer and legwise.export_printer against the command line: the same model
files, the same report, the same firmware lines; the command line's messages for bad input."""

import pytest

import legwise

from support import ROOT, command

CFG = str(ROOT / "tests" / "data" / "klipper" / "printer.cfg")
SIX = ["--rod-prior", "0", "--gain-prior", "0"]


def test_import_writes_the_command_lines_files(tmp_path):
    cli, py = tmp_path / "cli", tmp_path / "py"
    status, stdout, err = command("printer", "import", "--klipper", CFG, "--out", str(cli))
    assert status == 0, err
    imported = legwise.import_printer("klipper", CFG, py)
    for name in ("printer.yaml", "printer.urdf", "probe.csv"):
        assert (py / name).read_text() == (cli / name).read_text(), name
    assert imported.report == stdout.replace(str(cli), str(py))
    assert imported.probes == str(py / "probe.csv")
    # The default model: rods and gains on their priors beside Klipper's six.
    assert {"L1", "k1", "t1y", "h0_1"} <= set(imported.model.identified)


def test_import_identify_export_is_the_command_lines(tmp_path):
    cli, py = tmp_path / "cli", tmp_path / "py"
    options = ["--probe-noise", "5e-6", *SIX]
    assert command("printer", "import", "--klipper", CFG, "--out", str(cli), *options)[0] == 0
    cal = cli / "cal.yaml"
    status, _, err = command(
        "identify",
        "--model", str(cli / "printer.yaml"),
        "--measurements", str(cli / "probe.csv"),
        "--calibrated", str(cal),
    )
    assert status == 0, err
    imported = legwise.import_printer(
        "klipper", CFG, py, probe_noise=5e-6, rod_prior=0, gain_prior=0
    )
    report = imported.model.identify(imported.probes)
    assert report.trusted
    py_cal = py / "cal.yaml"
    report.write_calibrated(py_cal)
    status, values, summary = command(
        "printer", "export", "--klipper", "--calibrated", str(cal),
        "--firmware-config", CFG, "--out", "-",
    )
    assert status == 0, summary
    exported = legwise.export_printer(py_cal, "klipper", firmware_config=CFG)
    assert exported.values == values
    assert exported.summary == summary.replace(str(cal), str(py_cal))
    assert "#   [stepper_a] rotation_distance: 40.000000000" in exported.values
    assert "0.000 µm RMS" in exported.summary
    # The firmware's factor sets beside the model's own, on the same touches.
    table = legwise.sets(imported.model, imported.probes)
    assert "klipper-6" in table.text


def test_bad_printer_files_raise_the_command_lines_message(tmp_path):
    bad = tmp_path / "printer.cfg"
    bad.write_text(
        "[printer]\nkinematics: delta\ndelta_radius: 174.75\n"
        "[stepper_a]\nposition_endstop: 297.05\nrotation_distance: 40\nmicrosteps: 16\n"
    )
    status, _, err = command("printer", "import", "--klipper", str(bad), "--out", str(tmp_path / "a"))
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.import_printer("klipper", bad, tmp_path / "b")
    assert err == f"legwise: {caught.value}\n"
    assert "arm_length" in str(caught.value)
    with pytest.raises(legwise.LegwiseError, match="firmware: expected one of klipper, rrf, marlin"):
        legwise.import_printer("repetier", bad, tmp_path / "c")
    status, _, err = command(
        "printer", "export", "--rrf", "--calibrated", str(ROOT / "models" / "5r.yaml"), "--out", "-"
    )
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.export_printer(ROOT / "models" / "5r.yaml", "rrf")
    assert err == f"legwise: {caught.value}\n"
