"""The doStep counts of run.json (``fmu_calls``) and ``Runtime.do_step_calls``: every complete step counts each
component it stepped; a step cut short by an exception (an Exception the FMU raised, reported as a doStep failure,
or a KeyboardInterrupt that goes straight through) counts exactly the components it reached. The expectation is derived from the stepping order alone: every component stepped in each
complete step, and in the failing step those up to and including the failing one."""
import json
from pathlib import Path

import pytest

import master
from master.errors import CosimError
from master.execution import Execution
from master.fmi.inprocess import PythonFmuSlave

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"
KW = dict(stop_time=30.0, step=0.5, record=["*"], record_interval=0.5)
FAIL_AT = 3.0       # the 7th step (n = 6) fails


def _fail_in(monkeypatch, component, exc):
    orig = PythonFmuSlave.instantiate

    def instantiate(self):
        orig(self)
        if self.name == component:
            step = self.obj.do_step

            def do_step(t, h):
                if t >= FAIL_AT:
                    raise exc
                return step(t, h)
            self.obj.do_step = do_step
    monkeypatch.setattr(PythonFmuSlave, "instantiate", instantiate)


def _expected(names, order, failing, done):
    rank = {i: k for k, i in enumerate(order)}
    stop = rank[names.index(failing)]
    return {name: done + (1 if rank[i] <= stop else 0) for i, name in enumerate(names)}


def _names_and_order():
    with Execution(SSP, output=None, **KW) as ex:
        ex.initialize()
        return list(ex.rt.names), list(ex.algorithm.order)


@pytest.mark.parametrize("failing", ["wind", "uav1_dyn", "uav3_bat", "uav4_strat"])
def test_a_failing_step_counts_the_components_it_reached(tmp_path, monkeypatch, failing):
    names, order = _names_and_order()
    assert failing in names
    _fail_in(monkeypatch, failing, ZeroDivisionError("broke"))
    with pytest.raises(CosimError):
        master.run(SSP, output=tmp_path / "a", products="summary", **KW)     # run.json; no map (not the subject)
    meta = json.loads((tmp_path / "a" / "run.json").read_text())
    assert meta["steps_done"] == 6
    assert meta["fmu_calls"]["do_step"] == _expected(names, order, failing, 6)


def test_an_interrupt_in_a_step_counts_the_components_it_reached(monkeypatch):
    names, order = _names_and_order()
    _fail_in(monkeypatch, "uav2_dyn", KeyboardInterrupt())
    ex = Execution(SSP, output=None, **KW)
    ex.initialize()
    with pytest.raises(KeyboardInterrupt):
        ex.simulate_until()
    assert ex.n == 6
    assert dict(zip(ex.rt.names, ex.rt.do_step_calls)) == _expected(names, order, "uav2_dyn", 6)
    ex.close()


def test_counts_of_a_run_in_pieces():
    """Folded whenever the loop returns: after each ``step()`` the counts are those of the steps done."""
    with Execution(SSP, output=None, **KW) as ex:
        ex.initialize()
        for n in range(1, 6):
            ex.step()
            assert ex.rt.do_step_calls == [n] * len(ex.rt.names)
        ex.simulate_until(5.0)
        assert ex.rt.do_step_calls == [10] * len(ex.rt.names)
