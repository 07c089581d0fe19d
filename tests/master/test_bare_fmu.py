"""A bare .fmu runs and inspects like an SSP of one component (FMPy, OMSimulator and libcosim's ``cosim
run-single`` run one FMU directly): its default experiment, ``--input``, ``--param``, ``--record``, ``-o``."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from cli_in_process import run_cli

REFERENCE = Path(__file__).resolve().parents[2].parent / "shared" / "reference-fmus"


def _cli(args, cwd):
    """The command in this process (tests/cli_in_process.py): what it says and writes is what is checked here."""
    return run_cli(args, cwd)


def _reference(name: str) -> Path:
    fmu = REFERENCE / name
    if not fmu.is_file():
        pytest.skip(f"the Modelica Reference FMUs are not in {REFERENCE}")
    return fmu


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_reference_bouncing_ball_runs_from_its_default_experiment(tmp_path, version):
    fmu = _reference(f"{version}/BouncingBall.fmu")
    r = _cli(["run", fmu, "-o", tmp_path / "out"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    meta = json.loads((tmp_path / "out" / "run.json").read_text())
    assert meta["outcome"] == "completed" and meta["stop_time"] == 3.0 and meta["step_size"] == 0.01
    assert meta["settings_sources"]["start"] == meta["settings_sources"]["stop"] == "FMU DefaultExperiment"
    got = pd.read_parquet(tmp_path / "out" / "results.parquet")
    ref = pd.read_csv(REFERENCE / "ref" / "BouncingBall_out.csv")
    for col in ("h", "v"):     # the FMI cross-check band: within 10 % of the signal's range
        at_ref = np.interp(ref["time"], got["time"], got[f"BouncingBall.{col}"])
        assert np.max(np.abs(at_ref - ref[col])) <= 0.1 * np.ptp(ref[col])


def test_reference_bouncing_ball_inspects(tmp_path):
    fmu = _reference("fmi3/BouncingBall.fmu")
    r = _cli(["inspect", fmu, "--json"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)
    comp = info["components"]["BouncingBall"]
    assert comp["fmi_version"] == "3.0" and comp["source"] == str(fmu)
    assert {c["name"] for c in comp["connectors"]} >= {"h", "v"}
    assert info["settings"]["stop_time"] == 3.0
    assert info["default_experiment"] == {"start_time": 0.0, "stop_time": 3.0} and info["annotations"] == []
    text = _cli(["inspect", fmu], cwd=tmp_path).stdout
    assert "(a bare FMU, run as a system of this one component)" in text.splitlines()[0]
    assert "the FMU's default experiment: start 0.0, stop 3.0" in text


def test_reference_feedthrough_driven_by_its_input_file(tmp_path):
    fmu = _reference("fmi3/Feedthrough.fmu")
    r = _cli(["run", fmu, "--input", REFERENCE / "ref" / "Feedthrough_in.csv", "-o", tmp_path / "out",
              "--record", "Feedthrough.Int32_output"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    got = pd.read_parquet(tmp_path / "out" / "results.parquet")
    inputs = pd.read_csv(REFERENCE / "ref" / "Feedthrough_in.csv")
    # an integer input holds its row until the next (the exact timing is tests/master/fmi/test_input_files.py's)
    assert set(got["Feedthrough.Int32_output"]) == set(inputs["Int32_input"])
    assert got["Feedthrough.Int32_output"].iloc[-1] == inputs["Int32_input"].iloc[-1]


def test_built_fmu_with_input_param_and_record(tmp_path, test_fmus):
    fmu = tmp_path / "Gain.fmu"
    fmu.write_bytes(Path(test_fmus["c2:Gain"]).read_bytes())
    (tmp_path / "in.csv").write_text("time,u\n0,0\n1,2\n")
    r = _cli(["run", fmu, "--input", "in.csv", "--param", "Gain.k=3", "--record", "Gain.*", "--stop-time", "1",
              "--step", "0.25"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "results" / "Gain"           # the default output folder, named as the FMU
    got = pd.read_csv(out / "results.csv")
    assert list(got["time"]) == [0, 0.25, 0.5, 0.75, 1.0]
    # y = k u, u the table's ramp as the fixed-step master hands it over (one step behind, as for any SSP)
    assert np.allclose(got["Gain.y"], 3 * 2 * np.maximum(got["time"] - 0.25, 0))
    assert (got["Gain.k"] == 3).all()
    meta = json.loads((out / "run.json").read_text())
    assert meta["parameters_overridden"] == {"Gain.k": "3"}
    assert meta["scenario"] == str(fmu) or meta["scenario"].endswith("Gain.fmu")


def test_bare_fmu_from_the_python_api(tmp_path, test_fmus):
    r = master.run(test_fmus["c2:Gain"], output=None, stop_time=0.5, step=0.1, params={"Gain.k": 2.0})
    assert r.ok and list(r.frame.columns) == ["time", "Gain.y"]     # its outputs, recorded by default


@pytest.mark.parametrize("content", [None, b"not a zip"])
def test_bad_bare_fmu_is_one_line(tmp_path, content):
    fmu = tmp_path / "Bad.fmu"
    if content is not None:
        fmu.write_bytes(content)
    for command in (["run", fmu, "-o", tmp_path / "out"], ["inspect", fmu]):
        r = _cli(command, cwd=tmp_path)
        assert r.returncode == 1
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr and "Bad.fmu" in r.stderr, r.stderr


def test_array_outputs_are_recorded_by_default(tmp_path):
    fmu = _reference("fmi3/StateSpace.fmu")
    r = master.run(fmu, output=None, stop_time=0.1)
    assert [c for c in r.frame.columns if c != "time"] and all(c.startswith("StateSpace.y[")
                                                                for c in r.frame.columns if c != "time")


def test_a_file_name_that_is_no_uri(tmp_path, test_fmus):
    """Spaces and brackets in the file name: the component is named as the file, its archive member is not."""
    fmu = tmp_path / "my gain [v2].fmu"
    fmu.write_bytes(Path(test_fmus["c2:Gain"]).read_bytes())
    r = _cli(["run", fmu, "--param", "my gain [v2].k=2", "--record", "my gain [v2].k", "--stop-time", "0.2",
              "--step", "0.1", "-o", "out"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert list(pd.read_csv(tmp_path / "out" / "results.csv")["my gain [v2].k"]) == [2, 2, 2]


def test_a_refused_bare_fmu_names_no_line_of_the_ssd_made_for_it(tmp_path):
    fmu = _reference("fmi3/Clocks.fmu")
    r = _cli(["run", fmu, "-o", tmp_path / "out"], cwd=tmp_path)
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert f"error: {fmu}: Component Clocks: the FMU offers FMI 3.0 scheduled execution only" in r.stderr
