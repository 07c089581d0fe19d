"""Jacobi with concurrent doSteps (``threads``, master/algorithms/parallel.py).

Expectations: under Jacobi a component's step reads only outputs of the previous step, so running the doSteps of
one step at the same time cannot change a single bit (the sequential run, threads=1, is the reference); the
error of a failing step is the one the sequential step raises (the first failing component in component order);
and the doSteps really overlap, seen from the FMUs' own clock readings (Faulty mode 6 logs when each sleeping
doStep started and ended)."""
import json
import re

import pytest

import master
from cli_in_process import run_cli
from master.errors import CosimError
from master.ssp.writer import SspBuilder



def _oscillator(tmp_path, test_fmus, step=0.01, stop=5.0):
    b = SspBuilder("osc", stop=stop, step=step)
    b.add_component("A", test_fmus["c2:MassA"], params={"x0": 1.0})
    b.add_component("B", test_fmus["c2:MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / "osc.ssp")


def _chain(tmp_path, test_fmus):
    """Four components of two kinds, one with a feed-through (Gain), in a loop: I1 -> G -> I2 -> I3 -> I1."""
    b = SspBuilder("chain", stop=3.0, step=0.01)
    b.add_component("I1", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 1.0})
    b.add_component("G", test_fmus["c2:Gain"], params={"k": -0.7})
    b.add_component("I2", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 0.5})
    b.add_component("I3", test_fmus["c2:Integrator"], params={"a": -0.2, "x0": 0.0})
    b.connect("I1", "y", "G", "u")
    b.connect("G", "y", "I2", "u")
    b.connect("I2", "y", "I3", "u")
    b.connect("I3", "y", "I1", "u")
    return b.write(tmp_path / "chain.ssp")


def _run(ssp, **kw):
    return master.run(ssp, output=None, raise_on_error=False, **kw)


@pytest.mark.parametrize("threads", [2, 4])
@pytest.mark.parametrize("extra", [{}, {"step_multiples": {"B": 3}}, {"extrapolation": 1}],
                         ids=["plain", "multiple", "extrapolated"])
def test_the_oscillator_is_bit_identical_to_the_sequential_jacobi(tmp_path, test_fmus, threads, extra):
    ssp = _oscillator(tmp_path, test_fmus)
    ref = _run(ssp, record=["A.x", "A.v", "B.x", "B.F"], **extra)
    par = _run(ssp, record=["A.x", "A.v", "B.x", "B.F"], threads=threads, **extra)
    assert ref.metadata["outcome"] == par.metadata["outcome"] == "completed"
    assert len(ref.frame) == 501 and ref.frame.equals(par.frame)
    assert par.metadata["algorithm_info"]["threads"] == threads
    assert par.metadata["native_loop"]["used"] is False and "threads" in par.metadata["native_loop"]["reason"]


def test_a_four_component_loop_is_bit_identical_and_run_json_records_threads(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    rec = ["I1.y", "G.y", "I2.y", "I3.y"]
    ref = master.run(ssp, output=tmp_path / "ref", record=rec)
    for th in (2, 3, 4):
        par = master.run(ssp, output=tmp_path / f"t{th}", record=rec, threads=th)
        assert ref.frame.equals(par.frame), th
        meta = json.loads((tmp_path / f"t{th}" / "run.json").read_text())
        assert meta["settings_sources"]["threads"] == "command line"
        assert meta["algorithm_info"]["threads"] == th
    # the default is recorded too, from its source
    meta = json.loads((tmp_path / "ref" / "run.json").read_text())
    assert meta["settings_sources"]["threads"] == "default" and "threads" not in meta["algorithm_info"]


def _two_faulty(tmp_path, test_fmus, modes, fail_times, step=0.1, stop=1.0):
    b = SspBuilder("faulty2", stop=stop, step=step)
    for name, mode, ft in zip(("f1", "f2"), modes, fail_times):
        b.add_component(name, test_fmus["c2:Faulty"], params={"mode": mode, "fail_time": ft})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("f1", "y", "g", "u")
    return b.write(tmp_path / f"faulty_{'_'.join(map(str, modes))}_{'_'.join(map(str, fail_times))}.ssp")


@pytest.mark.parametrize("modes,fail_times,who", [
    ((1, 1), (0.5, 0.5), "f1"),       # both fail in the same step: the first in component order is named
    ((0, 1), (0.5, 0.5), "f2"),
    ((1, 1), (0.7, 0.5), "f2"),       # f2 fails two steps earlier
])
def test_an_error_in_a_thread_is_the_sequential_error_with_the_same_rows(tmp_path, test_fmus, modes, fail_times,
                                                                          who):
    ssp = _two_faulty(tmp_path, test_fmus, modes, fail_times)
    ref = _run(ssp, record=["f1.y", "f2.y", "g.y"])
    par = _run(ssp, record=["f1.y", "f2.y", "g.y"], threads=2)
    assert ref.metadata["outcome"] == par.metadata["outcome"] == "error"
    assert f"component {who}" in ref.metadata["error"] and ref.metadata["error"] == par.metadata["error"]
    # the step from min(fail_time) failed: rows at 0, 0.1, ..., that time are kept, the same in both runs
    assert len(ref.frame) == round(min(fail_times) / 0.1) + 1 and ref.frame.equals(par.frame)


def test_a_terminate_request_in_a_thread_ends_the_run_after_the_step_as_sequentially(tmp_path, test_fmus):
    ssp = _two_faulty(tmp_path, test_fmus, (0, 2), (0.5, 0.5))      # f2 discards with fmi2Terminated
    ref = _run(ssp, record=["f1.y", "g.y"])
    par = _run(ssp, record=["f1.y", "g.y"], threads=2)
    assert ref.metadata["outcome"] == par.metadata["outcome"] == "completed"
    assert "component f2 asked to terminate" in ref.metadata["ended_early"]["reason"]
    assert ref.metadata["ended_early"] == par.metadata["ended_early"] and ref.frame.equals(par.frame)
    assert len(par.frame) == 7      # the step from 0.5 asked to end: it completes, rows at 0, ..., 0.6


def test_the_cli_reports_a_failing_thread_in_one_line(tmp_path, test_fmus):
    ssp = _two_faulty(tmp_path, test_fmus, (1, 1), (0.5, 0.5))
    r = run_cli(["run", str(ssp), "-o", str(tmp_path / "o"), "--threads", "2"])
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.startswith("cosim-master:")]
    assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "component f1" in lines[0] and "t=0.5" in lines[0], lines[0]


def _sleep_intervals(log_text: str) -> dict[str, list[tuple[float, float]]]:
    out: dict[str, list[tuple[float, float]]] = {}
    for comp, a, b in re.findall(r"\] (\w+)(?:/\w+)?: sleep ([\d.]+) ([\d.]+)", log_text):
        out.setdefault(comp, []).append((float(a), float(b)))
    return out


def _max_concurrency(intervals) -> int:
    events = sorted([(a, 1) for a, _ in intervals] + [(b, -1) for _, b in intervals])
    now = best = 0
    for _, d in events:
        now += d
        best = max(best, now)
    return best


@pytest.mark.parametrize("threads,expected", [(1, 1), (2, 2)])
def test_the_doSteps_of_a_step_overlap_in_time(tmp_path, test_fmus, threads, expected):
    # mode 6 with fail_time < 0: every doStep sleeps and logs the FMU's monotonic clock at its start and end
    ssp = _two_faulty(tmp_path, test_fmus, (6, 6), (-1.0, -1.0), step=0.1, stop=0.5)
    res = master.run(ssp, output=tmp_path / "o", record=["f1.y"], threads=threads, log_level="info")
    assert res.metadata["outcome"] == "completed"
    spans = _sleep_intervals((tmp_path / "o" / "fmu.log").read_text())
    assert len(spans["f1"]) == len(spans["f2"]) == 5
    # sequential doSteps never overlap; with two threads the two sleeps of a step overlap (count-free: the
    # largest number of doSteps running at one instant, from the FMUs' own clock)
    assert _max_concurrency(spans["f1"] + spans["f2"]) == expected


@pytest.mark.parametrize("kw,element,reason", [
    ({"threads": 0}, "--threads", "must be >= 1"),
    ({"threads": -2}, "--threads", "must be >= 1"),
    ({"threads": 2.5}, "--threads", "expected an integer"),
    ({"threads": 2, "algorithm": "gauss-seidel"}, "--threads", "applies to jacobi only"),
    ({"threads": 2, "algorithm": "iterative"}, "--threads", "applies to jacobi only"),
])
def test_bad_threads_values_are_one_line_errors(tmp_path, test_fmus, kw, element, reason):
    with pytest.raises(CosimError) as e:
        master.run(_oscillator(tmp_path, test_fmus), output=None, **kw)
    text = str(e.value)
    assert element in text and reason in text and "\n" not in text, text


def test_bad_threads_on_the_command_line_is_one_line(tmp_path, test_fmus):
    r = run_cli(["run", str(_oscillator(tmp_path, test_fmus)), "-o", str(tmp_path / "o"), "--threads", "0"])
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.startswith("cosim-master:")]
    assert r.returncode != 0 and len(lines) == 1 and "--threads" in lines[0] and "Traceback" not in r.stderr


def test_threads_from_the_ssd_settings_annotation(tmp_path, test_fmus):
    b = SspBuilder("osc", stop=0.5, step=0.05, algorithm_options={"threads": 2})
    b.add_component("A", test_fmus["c2:MassA"], params={"x0": 1.0})
    b.add_component("B", test_fmus["c2:MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    res = master.run(b.write(tmp_path / "osc_ssd.ssp"), output=tmp_path / "o")
    meta = json.loads((tmp_path / "o" / "run.json").read_text())
    assert meta["settings_sources"]["threads"] == "SSD settings annotation"
    assert meta["algorithm_options"]["threads"] == 2 and res.metadata["algorithm_info"]["threads"] == 2
    # the command line wins over the SSD
    seq = master.run(tmp_path / "osc_ssd.ssp", output=None, threads=1)
    assert "threads" not in seq.metadata["algorithm_info"] and seq.frame.equals(res.frame)
