"""In-process FMUs (master/fmi/inprocess.py, written into the compiled step) against their binaries, run by
pythonfmu's own wrapper (inprocess=False): same rows bit for bit, same doStep counts, and failures reported as
through the FMI calls."""
import json
from pathlib import Path

import pytest

import master
from master.errors import CosimError
from master.execution import Execution
from master.fmi.inprocess import PythonFmuSlave

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"

KW = dict(stop_time=30.0, step=0.5, record=["*"], record_interval=0.5)


def _run(**kw):
    """The rows and doStep counts of a run kept in memory: the same table and the same ``fmu_calls`` that a run
    with an output folder writes to results.parquet and run.json, without the mission's map and files (most of a
    run's CPU here), which are not what differs between an in-process FMU and its binary."""
    res = master.run(SSP, output=None, **{**KW, **kw})
    return res.frame, res.metadata["fmu_calls"]


# Jacobi without step multiples (the SSD's own algorithm) is the same pair of runs as
# tests/fmu_sources/uavsim/test_uav_inprocess_cycle.py::test_cycle_runs_and_counts_like_the_binaries, which
# asserts all three of these checks on it
@pytest.mark.parametrize("algorithm, multiples", [("jacobi", {"uav2_strat": 2, "wind": 3}),
                                                  ("gauss-seidel", None), ("gauss-seidel", {"uav1_bat": 2})])
def test_inline_step_equals_the_binaries(algorithm, multiples):
    a, calls_a = _run(algorithm=algorithm, step_multiples=multiples, inprocess=True)
    b, calls_b = _run(algorithm=algorithm, step_multiples=multiples, inprocess=False)
    assert a.equals(b)
    assert calls_a == calls_b
    assert a["uav1_dyn.z"].max() > 5.0          # the vehicles flew: the inputs really reached them


def _dict_read_fails(monkeypatch, component):
    """``component``'s outputs read from an empty dict instead of its __dict__ (a KeyError, as for a missing
    attribute)."""
    orig = PythonFmuSlave._from_dict

    def from_dict(self, fetch):
        fetch, arg, names = orig(self, fetch)
        return (fetch, {}, names) if self.name == component and names is not None else (fetch, arg, names)
    monkeypatch.setattr(PythonFmuSlave, "_from_dict", from_dict)


def test_an_output_read_that_raises_is_read_through_the_fmi_call(monkeypatch):
    b, calls_b = _run()
    _dict_read_fails(monkeypatch, "uav3_dyn")
    a, calls_a = _run()
    assert a.equals(b) and calls_a == calls_b


def test_an_output_read_that_fails_is_reported_as_getting_outputs(tmp_path, monkeypatch):
    _dict_read_fails(monkeypatch, "uav3_dyn")

    def refuse(vrs):
        raise RuntimeError("output unavailable")
    with pytest.raises(CosimError) as err:
        with Execution(SSP, output=tmp_path / "a", products="summary", **KW) as ex:
            ex.initialize()
            obj = ex.rt.slaves[ex.rt.index["uav3_dyn"]].obj
            monkeypatch.setattr(obj, "get_real", refuse)
            monkeypatch.setattr(obj, "get_integer", refuse)
            ex.simulate_until()
    assert "uav3_dyn" in str(err.value) and "getting outputs" in str(err.value)
    assert err.value.__context__ is None or err.value.__suppress_context__
    meta = json.loads((tmp_path / "a" / "run.json").read_text())
    assert meta["outcome"] == "error" and meta["steps_done"] == 0 and meta["failed_at"] == 0.5
    assert meta["fmu_calls"]["do_step"]["uav3_dyn"] == 1          # it stepped, then its outputs failed
    assert "output unavailable" in (tmp_path / "a" / "fmu.log").read_text()


def test_a_do_step_that_raises_is_reported_and_counted(tmp_path, monkeypatch):
    orig = PythonFmuSlave.instantiate

    def instantiate(self):
        orig(self)
        if self.name == "uav2_bat":
            step = self.obj.do_step

            def do_step(t, h):
                if t >= 2.0:
                    raise ZeroDivisionError("cell model broke")
                return step(t, h)
            self.obj.do_step = do_step
    monkeypatch.setattr(PythonFmuSlave, "instantiate", instantiate)
    with pytest.raises(CosimError) as err:
        master.run(SSP, output=tmp_path / "a", products="summary", **KW)      # run.json and fmu.log, no map
    assert "uav2_bat" in str(err.value) and "doStep" in str(err.value)
    meta = json.loads((tmp_path / "a" / "run.json").read_text())
    assert meta["steps_done"] == 4 and meta["failed_at"] == 2.0
    calls = meta["fmu_calls"]["do_step"]
    assert calls["uav2_bat"] == 5 and calls["uav2_strat"] == 4    # the failing step counted; later ones not done
    assert "ZeroDivisionError: cell model broke" in (tmp_path / "a" / "fmu.log").read_text()
