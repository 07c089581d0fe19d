"""The in-process shortcut for the UAV FMUs (master/fmi/inprocess.py ``bound_cycle``: inputs and doStep in one
call): the same results and counts as the FMU binaries, and a failing input still reported as before."""
import json
from pathlib import Path

import pytest

import master
from master.errors import CosimError
from master.fmi.inprocess import PythonFmuSlave

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"
# products "summary": no map.png or trajectory.csv, drawn from the monitor's track, not the FMUs (half of a run
# here), and which no test here looks at
KW = dict(stop_time=30.0, step=0.5, record=["*"], record_interval=0.5, products="summary")


def _calls(folder):
    return json.loads((folder / "run.json").read_text())["fmu_calls"]


@pytest.fixture(scope="module")
def binaries(tmp_path_factory):
    """The run through the FMU binaries (the same for every test here): its frame and FMU call counts."""
    out = tmp_path_factory.mktemp("binaries")
    return master.run(SSP, output=out, inprocess=False, **KW).frame, _calls(out)


def test_cycle_runs_and_counts_like_the_binaries(tmp_path, binaries):
    used = []
    orig = PythonFmuSlave.bound_cycle

    def spy(self, *a):
        op = orig(self, *a)
        used.append(op is not None)
        return op
    mp = pytest.MonkeyPatch()
    mp.setattr(PythonFmuSlave, "bound_cycle", spy)
    try:
        a = master.run(SSP, output=tmp_path / "a", inprocess=True, **KW)
    finally:
        mp.undo()
    assert used and all(used)                 # every UAV FMU took the shortcut
    assert a.frame.equals(binaries[0])
    assert _calls(tmp_path / "a") == binaries[1]
    assert a.frame["uav1_dyn.z"].max() > 5.0          # the vehicles flew: the inputs really reached them


def _failing_set(monkeypatch, component, transient):
    """Make ``component``'s inline Real update raise (once if ``transient``; else its set_real raises too)."""
    orig = PythonFmuSlave._bound
    state = {"raised": 0}

    def bound(self, op, typ, vrs):
        found = orig(self, op, typ, vrs)
        if self.name != component or op != "set_raw" or typ != "Real" or found is None:
            return found
        update, names = found

        def flaky(pairs):
            if not transient or not state["raised"]:
                state["raised"] += 1
                raise RuntimeError("input rejected")
            return update(pairs)
        if not transient:
            def refuse(vrs, values):
                raise RuntimeError("input rejected")
            monkeypatch.setattr(self.obj, "set_real", refuse)
        return flaky, names
    monkeypatch.setattr(PythonFmuSlave, "_bound", bound)
    return state


def test_a_setter_that_raises_once_is_retried_through_the_fmi_call(tmp_path, monkeypatch, binaries):
    # as with the separate setters: the reporting path sets the inputs again, which succeeds: the run goes on,
    # with the results of an undisturbed run
    state = _failing_set(monkeypatch, "uav2_dyn", transient=True)
    a = master.run(SSP, output=tmp_path / "a", inprocess=True, **KW)
    monkeypatch.undo()
    assert state["raised"] == 1
    assert a.frame.equals(binaries[0])


def test_a_setter_that_fails_is_reported_as_setting_inputs(tmp_path, monkeypatch):
    _failing_set(monkeypatch, "uav2_dyn", transient=False)
    with pytest.raises(CosimError) as err:
        master.run(SSP, output=tmp_path / "a", inprocess=True, **KW)
    assert "uav2_dyn" in str(err.value) and "setting inputs" in str(err.value)
    meta = json.loads((tmp_path / "a" / "run.json").read_text())
    assert meta["outcome"] == "error" and meta["steps_done"] == 0
    assert "input rejected" in (tmp_path / "a" / "fmu.log").read_text()
