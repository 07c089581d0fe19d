"""Every kind of bad input gives one line naming the file, element or component, time and reason; nothing
recorded before a failure is lost; the command exits non-zero without a traceback."""
import json
import os
import sys
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from master.errors import CosimError, FmuError, ScenarioError

import program_server
from cli_in_process import run_cli
from ssd_text import component, connection, connector, experiment, inline_params, settings, ssd, write_folder, zip_folder

CLI = [sys.executable, "-m", "master.cli"]


def _faulty_ssd(mode, fail_time=0.5):
    params = ('<ssv:Parameter name="mode"><ssv:Integer value="%d"/></ssv:Parameter>'
              '<ssv:Parameter name="fail_time"><ssv:Real value="%r"/></ssv:Parameter>' % (mode, fail_time))
    f = component("f", "resources/Faulty.fmu", connector("y", "output"), inline_params(params))
    g = component("g", "resources/Gain.fmu", connector("u", "input") + connector("y", "output"))
    return ssd("faulty", f + g, connection("f", "y", "g", "u"), experiment_xml=experiment(1.0, settings(0.1)))


def _two(tmp_path, test_fmus, src_conn=None, dst_conn=None, conns=None):
    src_conn = src_conn or connector("y", "output")
    dst_conn = dst_conn or (connector("u", "input") + connector("y", "output"))
    a = component("a", "resources/Integrator.fmu", src_conn)
    b = component("b", "resources/Gain.fmu", dst_conn)
    xml = ssd("two", a + b, conns if conns is not None else connection("a", "y", "b", "u"),
              experiment_xml=experiment(1.0, settings(0.1)))
    return write_folder(tmp_path / "s", xml, {"Integrator.fmu": test_fmus["c2:Integrator"],
                                                "Gain.fmu": test_fmus["c2:Gain"]})


def _cli_process(args, cwd):
    """The command as a process of its own (forked by tests/program_server.py): what reaches its stderr when an
    error is not caught."""
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))
    return program_server.run(CLI + args, capture_output=True, text=True, cwd=cwd, env=env, timeout=120)


def _cli(args, cwd):
    """The command's messages and exit status, in this process (the program's own process: _cli_process)."""
    return run_cli(args, cwd)


def _one_line(msg: str):
    assert "\n" not in msg.strip() and "Traceback" not in msg


def test_missing_archive(tmp_path):
    with pytest.raises(ScenarioError) as e:
        master.run(tmp_path / "nope.ssp", output=None)
    assert str(e.value) == f"{tmp_path / 'nope.ssp'}: scenario not found"


def test_archive_that_is_not_a_zip(tmp_path):
    bad = tmp_path / "bad.ssp"
    bad.write_bytes(b"this is not a zip file")
    with pytest.raises(ScenarioError, match=r"bad\.ssp: not a readable SSP archive"):
        master.run(bad, output=None)


def test_archive_without_ssd(tmp_path):
    ssp = tmp_path / "empty.ssp"
    with zipfile.ZipFile(ssp, "w") as zf:
        zf.writestr("readme.txt", "nothing")
    with pytest.raises(ScenarioError, match=r"empty\.ssp: archive has no SystemStructure\.ssd"):
        master.run(ssp, output=None)


def test_invalid_xml_names_the_line(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    text = (folder / "SystemStructure.ssd").read_text().splitlines()
    text.insert(3, "<ssd:Broken")        # becomes line 4
    (folder / "SystemStructure.ssd").write_text("\n".join(text))
    with pytest.raises(ScenarioError) as e:
        master.run(folder, output=None)
    assert "SystemStructure.ssd:" in str(e.value) and "invalid XML" in str(e.value)
    assert e.value.line is not None and e.value.line >= 4


def test_schema_violation_names_the_line_and_reason(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, src_conn='<ssd:Connector name="y" kind="sideways"><ssc:Real/></ssd:Connector>')
    lines = (folder / "SystemStructure.ssd").read_text().splitlines()
    expected_line = next(i for i, l in enumerate(lines, 1) if 'kind="sideways"' in l)
    with pytest.raises(ScenarioError) as e:
        master.run(folder, output=None)
    assert e.value.line == expected_line
    assert "does not conform to the SSP schema" in str(e.value) and "sideways" in str(e.value)


def test_unknown_component_in_connection(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, conns=connection("a", "y", "nobody", "u"))
    with pytest.raises(ScenarioError, match=r"Connection a\.y -> nobody\.u: connection refers to unknown element 'nobody'"):
        master.run(folder, output=None)


def test_unknown_connector(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, src_conn=connector("z", "output"), conns=connection("a", "z", "b", "u"))
    with pytest.raises(ScenarioError, match=r"Connector a\.z: the FMU resources/Integrator\.fmu has no variable 'z'"):
        master.run(folder, output=None)


def test_connection_to_undeclared_connector(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, conns=connection("a", "y", "b", "w"))
    with pytest.raises(ScenarioError, match=r"component 'b' has no connector 'w' in the SSD"):
        master.run(folder, output=None)


def test_type_mismatch(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, src_conn=connector("y", "output", typ="Integer"))
    with pytest.raises(ScenarioError, match=r"Connector a\.y: type Integer does not match the FMU's type Real"):
        master.run(folder, output=None)


def test_causality_mismatch_is_found_before_instantiation(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, src_conn=connector("y", "input"))
    # a broken binary would fail at instantiation; the mismatch must be reported first
    _corrupt_binary(test_fmus["c2:Integrator"], folder / "resources" / "Integrator.fmu")
    with pytest.raises(ScenarioError, match=r"Connector a\.y: kind 'input' does not match the FMU's causality 'output'"):
        master.run(folder, output=None)


def test_connection_must_start_at_an_output(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus, conns=connection("b", "u", "a", "y"),
                  src_conn=connector("y", "output"))
    with pytest.raises(ScenarioError, match="a connection must start at an output"):
        master.run(folder, output=None)


def _corrupt_binary(src: Path, dst: Path):
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename.endswith(".so"):
                data = b"\x7fELF garbage"
            zout.writestr(item, data)


def test_fmu_binary_that_cannot_be_loaded(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    _corrupt_binary(test_fmus["c2:Integrator"], folder / "resources" / "Integrator.fmu")
    with pytest.raises(FmuError) as e:
        master.run(folder, output=None)
    assert "resources/Integrator.fmu: component a: cannot load the FMU's binary" in str(e.value)


def test_fmu_archive_that_is_not_a_zip(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    (folder / "resources" / "Gain.fmu").write_bytes(b"not a zip")
    with pytest.raises(FmuError, match=r"resources/Gain\.fmu: not a readable FMU archive"):
        master.run(folder, output=None)


@pytest.mark.parametrize("kind,mode,status,inprocess", [
    # (a Discard with fmi2Terminated, mode 2, ends a run normally: tests/master/fmi/test_fmi_conformance.py)
    ("c2", 1, "Error", True),
    # pythonfmu reports a Python exception as Fatal; the in-process path mirrors it. (An exception through
    # pythonfmu 0.7's binary over-releases a Python object: the interpreter crashes later in garbage
    # collection, so that combination is not exercised here.)
    ("py", 1, "Fatal", True)])
def test_fmu_failing_a_step_keeps_results(tmp_path, test_fmus, kind, mode, status, inprocess):
    folder = write_folder(tmp_path / "s", _faulty_ssd(mode), {"Faulty.fmu": test_fmus[f"{kind}:Faulty"],
                                                               "Gain.fmu": test_fmus["c2:Gain"]})
    out = tmp_path / "out"
    with pytest.raises(FmuError) as e:
        master.run(folder, output=out, inprocess=inprocess)
    msg = str(e.value)
    # the step from t=0.5 to 0.6 is the first to end after fail_time = 0.5
    assert "component f" in msg and "t=0.5" in msg and f"doStep returned {status}" in msg
    _one_line(msg)
    run = json.loads((out / "run.json").read_text())
    assert run["outcome"] == "error" and run["failed_at"] == 0.5 and run["error"] == msg
    for df in (pd.read_csv(out / "results.csv"), pd.read_parquet(out / "results.parquet")):
        assert list(df["time"]) == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5])
        assert list(df["f.y"]) == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5])


def test_cli_error_is_one_line_without_traceback(tmp_path, test_fmus):
    folder = write_folder(tmp_path / "s", _faulty_ssd(1), {"Faulty.fmu": test_fmus["c2:Faulty"],
                                                            "Gain.fmu": test_fmus["c2:Gain"]})
    res = _cli(["run", str(folder), "--output", str(tmp_path / "out")], tmp_path)     # the message: in-process
    assert res.returncode == 1
    lines = res.stderr.strip().splitlines()
    # the FMU's own log line (shown per component at the default level) comes first, then the error
    assert lines[0] == "[error] f: Faulty: injected error in doStep(t=0.5, h=0.1), fail_time=0.5"
    err = lines[1:]
    assert len(err) == 1 and err[0].startswith("cosim-master: error: ") and "Traceback" not in res.stderr
    assert "component f" in err[0] and "t=0.5" in err[0]
    assert (tmp_path / "out" / "results.csv").read_text().count("\n") == 7   # header + 6 rows
    res = _cli_process(["run", str(folder), "--output", str(tmp_path / "out2"), "--debug"], tmp_path)
    assert res.returncode != 0 and "Traceback" in res.stderr


def test_cli_bad_parameter_value(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    res = _cli(["run", str(folder), "--param", "b.k=abc", "--output", str(tmp_path / "o")], tmp_path)
    assert res.returncode == 1
    assert res.stderr.strip() == "cosim-master: error: --param b.k: 'abc' is not a valid Real for b.k"


def test_cli_unknown_parameter(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    res = _cli(["run", str(folder), "--param", "b.nothing=1", "--output", str(tmp_path / "o")], tmp_path)
    assert res.returncode == 1
    assert "component 'b' has no variable 'nothing'" in res.stderr and "Traceback" not in res.stderr


def test_stop_time_not_a_whole_number_of_steps_ends_with_a_shorter_step(tmp_path, test_fmus):
    # 1.0 s in steps of 0.3: three steps and a last one of 0.1 (as fmpy does); explicit Euler on y' = -y
    folder = _two(tmp_path, test_fmus)
    r = master.run(folder, output=tmp_path / "o", step=0.3, params={"a.x0": 1.0, "a.a": -1.0}, record=["a.y"])
    df = r.frame
    np.testing.assert_allclose(df["time"], [0.0, 0.3, 0.6, 0.9, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(df["a.y"], [1.0, 0.7, 0.49, 0.343, 0.343 * 0.9], rtol=1e-14)
    assert r.metadata["steps"] == 4 and r.metadata["last_step"] == pytest.approx(0.1)
    # a component on a step multiple needs whole steps: refused as before
    with pytest.raises(CosimError, match="not a whole number of master steps of 0.3.*step multiple"):
        master.run(folder, output=None, step=0.3, step_multiples={"b": 2})


@pytest.mark.parametrize("k", [-1, 0])
def test_step_multiple_must_be_positive(tmp_path, test_fmus, k):
    # -1 used to run with wrong values and exit 0; 0 ended in a ZeroDivisionError traceback
    folder = _two(tmp_path, test_fmus)
    with pytest.raises(CosimError, match=f"step multiple of b must be a positive integer, got {k}"):
        master.run(folder, output=None, step_multiples={"b": k})
    r = _cli(["run", str(folder), "--step-multiple", f"b={k}", "-o", str(tmp_path / "o")], tmp_path)
    assert r.returncode == 1 and "must be a positive integer" in r.stderr
    _one_line(r.stderr)


@pytest.mark.parametrize("args,expected", [
    (["--stop-time", "nan"], "--stop-time: must be a finite time in seconds, got nan"),
    (["--stop-time", "inf"], "--stop-time: must be a finite time in seconds, got inf"),
    (["--start-time=-inf"], "--start-time: must be a finite time in seconds, got -inf"),
    (["--record-interval", "nan"], "--record-interval: record interval must be a positive finite number of seconds, "
                                   "got nan"),
    (["--record-interval", "0"], "--record-interval: record interval must be a positive finite number of seconds, "
                                 "got 0.0"),
    (["--record-interval", "-1"], "--record-interval: record interval must be a positive finite number of seconds, "
                                  "got -1.0"),
    (["--timeout", "0"], "--timeout: must be a positive number of seconds"),
    # issue 25: an OverflowError traceback; a warning of a 300-digit step count and a run for ever
    (["--stop-time", "1e308"], "settings: 0..1e+308 s in steps of 0.1 s is inf steps, more than any run can take"),
    (["--step", "1e-300"], "settings: 0..1 s in steps of 1e-300 s is 1e+300 steps, more than any run can take"),
    # issue 25: shown as "inf", not as written; --timeout 1e400 ran without a timeout
    (["--stop-time", "1e400"], "--stop-time: must be a finite time in seconds, got 1e400"),
    (["--step", "1e400"], "--step: step size must be a positive finite number of seconds, got 1e400"),
    (["--record-interval=-1e400"], "--record-interval: record interval must be a positive finite number of "
                                      "seconds, got -1e400"),
    (["--timeout", "1e400"], "--timeout: must be a positive number of seconds, got 1e400"),
    # issue 25: blamed on the SSD's DefaultExperiment
    (["--stop-time=-5"], "--stop-time: stop time -5 (command line) is not after start time 0 (SSD DefaultExperiment)"),
    (["--start-time", "5"], "--start-time: stop time 1 (SSD DefaultExperiment) is not after start time 5 "
                            "(command line)"),
    (["--step", "0.3", "--record-interval", "1"], "--record-interval: record interval 1 (command line) is not a "
                                                  "whole multiple of the step 0.3 (command line)"),
])
def test_bad_numbers_on_the_command_line_are_one_line(tmp_path, test_fmus, args, expected):
    r = _cli(["run", str(_two(tmp_path, test_fmus)), "-o", str(tmp_path / "o")] + args, tmp_path)
    assert r.returncode == 1 and expected in r.stderr, r.stderr
    _one_line(r.stderr)


@pytest.mark.parametrize("args,expected", [
    # issue 25: "inf is not a finite value" for a number the user wrote finite; --allow-nonfinite took it as inf
    (["--param", "a.x0=1e400"], "--param a.x0: '1e400' is not a valid Real for a.x0"),
    (["--param", "a.x0=-1e400"], "--param a.x0: '-1e400' is not a valid Real for a.x0"),
    (["--param", "a.x0=1e400", "--allow-nonfinite"], "--param a.x0: '1e400' is not a valid Real for a.x0"),
    (["--param", "b.k=1E+400"], "--param b.k: '1E+400' is not a valid Real for b.k"),
])
def test_a_number_beyond_a_double_is_shown_as_written(tmp_path, test_fmus, args, expected):
    r = _cli(["run", str(_two(tmp_path, test_fmus)), "-o", str(tmp_path / "o")] + args, tmp_path)
    assert r.returncode == 1 and r.stderr.strip() == f"cosim-master: error: {expected}", r.stderr
    assert not (tmp_path / "o" / "results.csv").exists()


def test_infinity_asked_for_by_name_is_still_infinity():
    from master.values import parse_text
    assert parse_text("Real", "inf") == float("inf") and parse_text("Real", "-Infinity") == float("-inf")
    assert parse_text("Real", "1.7976931348623157e308") == 1.7976931348623157e308
    with pytest.raises(ValueError, match="1e309: out of range for a 64-bit float"):
        parse_text("Real", "1e309")


@pytest.mark.parametrize("yaml_tail,expected", [
    # issue 25: a ValueError traceback (YAML reads 1.0e+400 as infinity)
    ("grid:\n  param:a.x0: [1.0]\nrun:\n  stop_time: 1.0e+400\n",
     "c.yaml: run.stop_time: non-finite number inf (.inf, .nan, or a number beyond a 64-bit float's range of "
     "±1.8e308)"),
    ("grid:\n  param:a.x0: [1.0e+400]\n", "c.yaml: grid.param:a.x0: non-finite number inf (.inf, .nan, or a "
                                           "number beyond"),
    # written without a dot, YAML 1.2 reads it as a number too (master/yamlio.py), so the same message
    ("grid:\n  param:a.x0: [1e400]\n", "c.yaml: grid.param:a.x0: non-finite number inf (.inf, .nan, or a "
                                        "number beyond"),
    ("grid:\n  param:a.x0: [1.0]\nrun:\n  stop_time: 1e400\n",
     "c.yaml: run.stop_time: non-finite number inf (.inf, .nan, or a number beyond a 64-bit float's range of "
     "±1.8e308)"),
])
def test_campaign_numbers_beyond_a_double_are_one_line(tmp_path, test_fmus, yaml_tail, expected):
    folder = _two(tmp_path, test_fmus)
    (tmp_path / "c.yaml").write_text(f"name: c\nscenario: {folder}\n{yaml_tail}")
    r = _cli(["campaign", "c.yaml", "-o", "out", "--no-progress", "--workers", "1"], tmp_path)
    assert r.returncode == 1 and expected in r.stderr, r.stderr
    _one_line(r.stderr)


def test_another_campaign_into_a_campaign_folder_is_one_line(tmp_path, test_fmus):
    """issue 25: it silently replaced the folder's campaign.yaml, table and report."""
    folder = _two(tmp_path, test_fmus)
    (tmp_path / "c.yaml").write_text(f"name: c\nscenario: {folder}\ngrid:\n  param:a.x0: [1.0]\n")
    (tmp_path / "d.yaml").write_text(f"name: d\nscenario: {folder}\ngrid:\n  param:a.x0: [2.0]\n")
    assert _cli(["campaign", "c.yaml", "-o", "out", "--no-progress", "--workers", "1"], tmp_path).returncode == 0
    r = _cli(["campaign", "d.yaml", "-o", "out", "--no-progress", "--workers", "1"], tmp_path)
    assert r.returncode == 1 and "--output: the folder holds the campaign 'c', not 'd': give another -o DIR" \
        in r.stderr, r.stderr
    _one_line(r.stderr)
    assert (tmp_path / "out" / "campaign.yaml").read_text().startswith("name: c")


# Elsewhere in the corpus of issue 25 (signals and disks need their own set-up):
#  - a full disk / file size limit keeps every row that fitted: tests/master/test_faults.py
#    (test_a_full_disk_*, test_a_file_size_limit_keeps_every_row_that_fitted)
#  - Ctrl-C / SIGTERM while the program starts: tests/master/test_interrupts.py
#  - campaign Ctrl-C 130, SIGTERM 143: tests/master/campaign/test_campaign_run.py, test_campaign_sigterm.py
#  - report's progress bar: tests/master/test_progress.py


def test_a_step_against_the_ssds_record_interval_names_both(tmp_path, test_fmus):
    """issue 25: --step 0.3 against an SSD's recordInterval was reported as a --record-interval problem when no
    --record-interval was given."""
    folder = _two(tmp_path, test_fmus)
    ssd_file = folder / "SystemStructure.ssd"
    ssd_file.write_text(ssd_file.read_text().replace('stepSize="0.1"', 'stepSize="0.1" recordInterval="0.5"'))
    r = _cli(["run", str(folder), "--step", "0.3", "-o", str(tmp_path / "o")], tmp_path)
    assert r.returncode == 1, r.stderr
    assert ("Settings recordInterval: record interval 0.5 (SSD) is not a whole multiple of the step 0.3 "
            "(command line); give a --record-interval that is") in r.stderr
    _one_line(r.stderr)


@pytest.mark.parametrize("where", ["afile", "afile/sub"])
def test_an_output_folder_that_is_a_file(tmp_path, test_fmus, where):
    """issue 25: "File exists"."""
    (tmp_path / "afile").write_text("mine")
    r = _cli(["run", str(_two(tmp_path, test_fmus)), "-o", where], tmp_path)
    assert r.returncode == 1 and "--output: the output folder " in r.stderr and "which is a file" in r.stderr \
        if "/" in where else "is a file, not a folder" in r.stderr, r.stderr
    _one_line(r.stderr)
    assert (tmp_path / "afile").read_text() == "mine"


def _faulty_only(tmp_path, test_fmus):
    xml = ssd("f", component("f", "resources/Faulty.fmu", connector("y", "output")), "",
              experiment_xml=experiment(1.0, settings(0.1)))
    return write_folder(tmp_path / "f", xml, {"Faulty.fmu": test_fmus["c2:Faulty"]})


def test_integer_values_are_range_checked(tmp_path, test_fmus):
    # a binary FMU would cut 2**32 + 7 to 7 while an in-process Python one keeps it: refuse it everywhere
    with pytest.raises(ScenarioError, match=r"4294967303 is out of range for f.mode \(Integer: -2147483648..2147483647\)"):
        master.run(_faulty_only(tmp_path, test_fmus), output=None, params={"f.mode": 4294967303})
    with pytest.raises(ScenarioError, match=r"--param f.mode: -2147483649 is out of range"):
        master.run(_faulty_only(tmp_path, test_fmus), output=None, params={"f.mode": "-2147483649"})


def test_nonfinite_parameters_and_outputs_stop_the_run(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    with pytest.raises(ScenarioError, match="nan is not a finite value for a.x0"):
        master.run(folder, output=None, params={"a.x0": "nan"})
    # y += h (a y + u) from 1e308 with a = 10 overflows to inf in the first step: the run stops there, the row
    # that shows it is recorded, and the message names the variable
    with pytest.raises(CosimError, match=r"component a: t=0.1: non-finite output a.y = inf.*--allow-nonfinite"):
        master.run(folder, output=tmp_path / "out", params={"a.x0": 1e308, "a.a": 10.0}, record=["a.y"])
    df = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert len(df) == 2 and df["a.y"].iloc[0] == 1e308 and np.isinf(df["a.y"].iloc[1])
    ok = master.run(folder, output=None, params={"a.x0": "inf"}, allow_nonfinite=True, record=["a.y"])
    # x0 = inf, a = 0: y = inf, then 0 * inf = NaN from the first step on, and the run goes to its end
    y = ok.frame["a.y"]
    assert len(y) == 11 and np.isinf(y.iloc[0]) and np.isnan(y.iloc[1:]).all()


def test_a_practically_endless_run_is_announced(tmp_path, test_fmus, caplog):
    from master.execution import Execution
    ex = Execution(_two(tmp_path, test_fmus), output=None, step=1e-9)
    with caplog.at_level("WARNING", logger="cosim_master"):
        ex.setup()
    ex.close()
    assert "1,000,000,000 steps of 1e-09 s from 0 to 1 s: this run may take very long" in caplog.text


def test_a_scenario_yaml_given_to_run_says_to_build_it(tmp_path):
    scenario = Path(__file__).parents[2] / "ssp" / "scenarios" / "paper_area.yaml"
    r = _cli(["run", str(scenario), "-o", str(tmp_path / "o")], tmp_path)
    assert r.returncode == 1 and "this is a UAV YAML scenario, not an SSP: build one with `cosim-master " \
                                  f"build-scenario {scenario} -o scenario.ssp`" in r.stderr
    _one_line(r.stderr)


def test_files_beside_a_bare_ssd_are_named_by_their_own_path(tmp_path, test_fmus):
    folder = _two(tmp_path, test_fmus)
    (folder / "resources" / "Gain.fmu").write_bytes(b"not a zip")
    with pytest.raises(FmuError) as e:
        master.run(folder / "SystemStructure.ssd", output=None)
    # not ".../SystemStructure.ssd/resources/Gain.fmu"
    assert str(e.value).startswith(f"{folder / 'resources' / 'Gain.fmu'}: not a readable FMU archive")


def test_an_fmu_without_binaries_for_this_platform_says_which_it_has(tmp_path, test_fmus):
    src = zipfile.ZipFile(test_fmus["c2:Gain"])
    fmu = tmp_path / "WinGain.fmu"
    with zipfile.ZipFile(fmu, "w") as out:
        for item in src.infolist():
            name = item.filename.replace("binaries/linux64/", "binaries/win64/")
            out.writestr(name, src.read(item.filename))
    b = component("g", "resources/Gain.fmu", connector("u", "input") + connector("y", "output"))
    folder = write_folder(tmp_path / "w", ssd("w", b, "", experiment_xml=experiment(1.0, settings(0.1))),
                          {"Gain.fmu": fmu})
    with pytest.raises(FmuError, match="component g: this FMU has binaries for win64 only, not for linux64"):
        master.run(folder, output=None)


def test_a_fleet_too_large_to_build_is_refused_at_once(tmp_path):
    """issue 25: `build-scenario` with n_uavs: 100000 worked silently for minutes."""
    shipped = Path(master.__file__).parents[1] / "ssp" / "scenarios" / "paper_area.yaml"
    text = shipped.read_text()
    assert "\nn_uavs:" in text
    big = tmp_path / "big.yaml"
    big.write_text("\n".join("n_uavs: 100000" if line.startswith("n_uavs:") else line for line in text.splitlines()))
    r = _cli(["build-scenario", str(big), "-o", str(tmp_path / "big.ssp")], tmp_path)
    assert r.returncode == 1 and "n_uavs: 100000 UAVs, at most 4096" in r.stderr, r.stderr
    _one_line(r.stderr)
    assert not (tmp_path / "big.ssp").exists()


@pytest.mark.parametrize("args,expected", [
    (["run", "x.ssp", "--seed", "abc"], "cosim-master run: error: argument --seed: invalid int value: 'abc' "
                                        "(see cosim-master run --help)"),
    (["run", "x.ssp", "--stop-time", "abc"], "argument --stop-time: invalid number value: 'abc'"),
    (["inspect", "x.ssp", "--step", "abc"], "cosim-master inspect: error: argument --step: invalid number value"),
    (["run"], "the following arguments are required: scenario"),
    (["bogus"], "argument command: invalid choice: 'bogus'"),
])
def test_usage_errors_are_one_line(tmp_path, args, expected):
    """A usage error was the whole usage (a dozen lines for run) and then the reason."""
    r = _cli(args, tmp_path)
    assert r.returncode == 2 and expected in r.stderr, r.stderr
    _one_line(r.stderr)


def test_an_input_file_is_named_as_given(tmp_path, test_fmus):
    """A bad cell of --input FILE was named as a member of the scenario (scenario.ssp/in.csv:2)."""
    gain = tmp_path / "Gain.fmu"
    gain.write_bytes(Path(test_fmus["c2:Gain"]).read_bytes())
    (tmp_path / "in.csv").write_text("time,u\n0,abc\n")
    r = _cli(["run", "Gain.fmu", "--input", "in.csv", "-o", "out"], tmp_path)
    assert r.returncode == 1 and "error: in.csv:2: 'abc' in column 'u' is not a valid Real" in r.stderr, r.stderr
    _one_line(r.stderr)
