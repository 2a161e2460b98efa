"""legwise.Mechanism: a model file loaded as the commands load it, usable wherever a model path
is; a pandas DataFrame as measurements."""

import pytest

import legwise

from support import MODEL, command, model, without_timings


def test_a_mechanism_describes_its_model_as_the_report_does():
    mechanism = legwise.Mechanism(MODEL)
    assert mechanism.legs == ["leg1", "leg2"]
    assert mechanism.measured == ["x", "y"] and mechanism.instrument is None
    report = legwise.identify(mechanism, noise_scale=0).to_dict()
    identified = []
    for leg in report["results"][0]["legs"]:
        for p in leg["parameters"]:
            described = mechanism.parameters[p["name"]]
            assert described.nominal == p["nominal"] and described.owner == leg["name"]
            # The model's simulation with its own seed: the report's real mechanism.
            assert described.real == p["real"]
            assert described.identified == (not p["fixed"])
            identified += [p["name"]] if not p["fixed"] else []
    assert mechanism.identified == identified and len(identified) == 12


def test_a_mechanism_is_a_model_path_everywhere():
    mechanism = legwise.Mechanism(MODEL)
    by_path = legwise.identify(MODEL, noise_scale=0).to_dict()
    assert without_timings(mechanism.identify(noise_scale=0).to_dict()) == without_timings(by_path)
    assert list(mechanism.simulate(seed=4)["x"]) == list(legwise.simulate(MODEL, seed=4)["x"])
    assert repr(mechanism) == f"legwise.Mechanism({MODEL!r})"


def test_an_instrument_is_described_with_its_columns_and_parameters():
    mechanism = legwise.Mechanism(model("delta-probe-poses.yaml"))
    assert mechanism.instrument["forward"] is True
    assert mechanism.instrument["columns"] == ["z.nozzle"]
    assert mechanism.readings == ["C1", "C2", "C3"]
    owners = {p.owner for p in mechanism.parameters.values()}
    assert owners == {"leg1", "leg2", "leg3", "instrument"}
    report = legwise.identify(mechanism, noise_scale=0).to_dict()["results"][0]
    for p in report["instrument"]["parameters"]:
        assert mechanism.parameters[p["name"]].real == p["real"]
    assert len(mechanism.identified) == 18


def test_a_bad_model_raises_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nurdf: missing.urdf\n")
    status, _, err = command("select", "--model", str(bad), "--out", "-")
    assert status == 2
    with pytest.raises(legwise.LegwiseError) as caught:
        legwise.Mechanism(bad)
    assert err == f"legwise: {caught.value}\n"


def test_a_pandas_dataframe_is_read_as_the_csv_it_came_from(tmp_path):
    pandas = pytest.importorskip("pandas")
    path = tmp_path / "m.csv"
    status, _, err = command("simulate", "--model", MODEL, "--seed", "5", "--out", str(path))
    assert status == 0, err
    frame = pandas.read_csv(path)
    # As pandas reads the file: the shared rows' empty `leg` and the readings not taken as NaN.
    assert frame["leg"].isna().any() and frame["A2"].isna().any()
    from_frame = legwise.identify(MODEL, frame).to_dict()
    from_file = legwise.identify(MODEL, path).to_dict()
    assert from_frame.pop("measurements") == legwise._native.MEMORY_NAME
    from_file.pop("measurements")
    assert without_timings(from_frame) == without_timings(from_file)


def test_the_example_runs_and_the_calibration_helps(tmp_path):
    pytest.importorskip("pandas")
    pytest.importorskip("matplotlib")
    import shutil
    import subprocess
    import sys

    from support import ROOT

    shutil.copytree(ROOT / "models", tmp_path / "models")
    status, _, err = command(
        "simulate", "--model", "models/5r.yaml", "--out", "m.csv", cwd=tmp_path
    )
    assert status == 0, err
    run = subprocess.run(
        [sys.executable, str(ROOT / "python" / "examples" / "identify_5r.py"), "m.csv"],
        cwd=tmp_path, capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "5r-errors.png").stat().st_size > 0
    assert (tmp_path / "5r-calibrated.urdf").exists()
    last = run.stdout.splitlines()[-1]
    nominal, calibrated = [float(w) for w in last.replace(",", "").split() if w[0].isdigit()]
    assert calibrated < nominal / 10, last
