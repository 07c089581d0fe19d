"""No communication point passes the stop time, and the last one is the stop time exactly, whatever computes the
steps: the reference loop, the native step driver, Gauss-Seidel, iterative and adaptive steps.

The FMU that sees it is tests/fmu_factory.py's Faulty (mode 0: never fails): its output y is its own time after
each doStep, currentCommunicationPoint + communicationStepSize as the FMU adds them.  With steps of 0.1 s to
50 s, n h is exact at n = 500 (0.1 * 500 == 50.0) but the last step starts at 499 * 0.1 = 49.900000000000006, so
a step of h ends at 50.00000000000001: past the stop time given in fmi2SetupExperiment, where "if the environment
tries to compute past stopTime the FMU has to return fmi2Error" (FMI 2.0.x, 2.1.6; Ecos's dp_ship FMI 1.0 FMU
does). The last step is now stop - t_499 = 0.09999999999999432 long and ends at 50.0.
"""
import numpy as np
import pytest

import master
from master.runtime import Runtime
from master.settings import count_steps
from master.ssp.writer import SspBuilder


def _clock_ssp(tmp_path, test_fmus, stop, step):
    b = SspBuilder("clock", stop=stop, step=step)
    b.add_component("clock", test_fmus["c2:Faulty"], params={"mode": 0, "fail_time": 1e9})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("clock", "y", "g", "u")
    return b.write(tmp_path / "clock.ssp")


@pytest.mark.parametrize("stop,step", [(50.0, 0.1), (0.3, 0.1), (1.0, 0.3), (10.0, 0.5)])
def test_the_last_step_ends_at_the_stop_time_as_the_fmu_adds_it(stop, step):
    n, last = count_steps(0.0, stop, step, allow_partial=True)
    t = (n - 1) * step
    assert t + (last if last is not None else step) == stop
    if last is None:                  # nothing to correct: bit-identical to before
        assert n * step == stop and (n - 1) * step + step == stop
    else:
        assert last <= step * (1 + 1e-9)


RUNS = [("jacobi", {}), ("jacobi", {"native_loop": False}), ("gauss-seidel", {})]


@pytest.mark.parametrize("algorithm,options", RUNS, ids=[f"{a}{'-python' if o else ''}" for a, o in RUNS])
def test_no_communication_point_past_the_stop_time(tmp_path, test_fmus, algorithm, options):
    r = master.run(_clock_ssp(tmp_path, test_fmus, 50.0, 0.1), output=None, record=["*"], algorithm=algorithm,
                   **options)
    df = r.frame
    time, fmu_time = df["time"].to_numpy(), df["clock.y"].to_numpy()
    assert time[-1] == 50.0 and time.max() == 50.0 and len(df) == 501
    assert fmu_time[-1] == 50.0 and fmu_time.max() == 50.0         # the FMU's own t + h, not the master's n h
    assert np.all(np.diff(fmu_time) > 0)
    assert r.metadata["last_time"] == 50.0
    if algorithm == "jacobi" and not options and "native_loop" in r.metadata:
        # the driver runs the full steps, the reference loop the corrected last one
        assert not r.metadata["native_loop"].get("used") or r.metadata["native_loop"]["steps"] == 499


def test_a_stop_time_that_is_no_multiple_ends_with_the_remainder(tmp_path, test_fmus):
    # 1.0 s in steps of 0.3: 0.3, 0.6, 0.9 (as 3 * 0.3 = 0.8999999999999999), then the rest, 0.1
    df = master.run(_clock_ssp(tmp_path, test_fmus, 1.0, 0.3), output=None, record=["*"]).frame
    assert df["time"].tolist() == [0.0, 0.3, 0.6, 0.8999999999999999, 1.0]
    assert df["clock.y"].iloc[-1] == 1.0 and df["clock.y"].max() == 1.0


def _masses_ssp(tmp_path, test_fmus):
    """Two coupled masses (tests/fmu_factory.py: MassA, MassB), which save and restore their state: what the
    iterative and adaptive algorithms roll back."""
    b = SspBuilder("masses", stop=50.0, step=0.1)
    b.add_component("A", test_fmus["c2:MassA"])
    b.add_component("B", test_fmus["c2:MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / "masses.ssp")


def test_adaptive_steps_end_at_the_stop_time(tmp_path, test_fmus, monkeypatch):
    # the adaptive algorithm takes its doSteps through Runtime.fast_ops: each (t, h) it passes is recorded
    calls = []
    fast_ops = Runtime.fast_ops

    def recording(self, i, setters=True):
        ops = list(fast_ops(self, i, setters))
        step = ops[2]
        ops[2] = lambda t, h: calls.append(t + h) or step(t, h)
        return tuple(ops)

    monkeypatch.setattr(Runtime, "fast_ops", recording)
    r = master.run(_masses_ssp(tmp_path, test_fmus), output=None, algorithm="adaptive", step_rtol=1e-2)
    assert len(calls) > 1000 and max(calls) == 50.0 and calls[-1] == 50.0
    assert r.frame["time"].iloc[-1] == 50.0 and r.frame["time"].max() == 50.0 and r.metadata["last_time"] == 50.0


def test_iterative_ends_at_the_stop_time(tmp_path, test_fmus):
    # its steps are the compiled step of jacobi and gauss-seidel (checked on the FMU's clock above), iterated
    r = master.run(_masses_ssp(tmp_path, test_fmus), output=None, algorithm="iterative")
    assert r.frame["time"].iloc[-1] == 50.0 and r.frame["time"].max() == 50.0 and len(r.frame) == 501


# -- components on a step multiple k > 1: their last macro step ends at the stop time too -------------------------

def test_final_macro_steps_end_at_the_stop_time_as_the_fmu_adds_them():
    from master.settings import final_macro_steps
    # k = 2, 0.1 s to 50 s: the last macro step starts at n = 498, 49.800000000000004, and 0.2 from there ends at
    # 50.00000000000001; k = 5: 495 * 0.1 + 0.5 is 50.0 (nothing to correct); k = 3, 0.1 s to 1 s: 10 steps are no
    # whole number of macro steps, the last starts at n = 9 and would end at 1.2
    assert 498 * 0.1 + 2 * 0.1 > 50.0 and 495 * 0.1 + 5 * 0.1 == 50.0
    final = final_macro_steps(0.0, 50.0, 0.1, 500, {"a": 2, "b": 5, "c": 1})
    assert set(final) == {"a"} and final["a"][0] == 498 and 498 * 0.1 + final["a"][1] == 50.0
    n0, length = final_macro_steps(0.0, 1.0, 0.1, 10, {"s": 3})["s"]
    assert n0 == 9 and 9 * 0.1 + length == 1.0 and length < 0.1 + 1e-12


def _multirate_clock(tmp_path, test_fmus, stop, step, k):
    b = SspBuilder("clock", stop=stop, step=step, step_multiples={"clock": k})
    b.add_component("clock", test_fmus["c2:Faulty"], params={"mode": 0, "fail_time": 1e9})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("clock", "y", "g", "u")
    return b.write(tmp_path / f"clock{k}.ssp")


MULTIRATE = [("jacobi", {}), ("jacobi", {"native_loop": False}), ("jacobi", {"threads": 2}), ("gauss-seidel", {}),
             ("jacobi", {"pure_python": True})]


@pytest.mark.parametrize("stop,step,k", [(50.0, 0.1, 2), (1.0, 0.1, 3), (0.3, 0.1, 3)])
@pytest.mark.parametrize("algorithm,options", MULTIRATE,
                         ids=[f"{a}-{'-'.join(o) or 'default'}" for a, o in MULTIRATE])
def test_a_component_on_a_step_multiple_ends_at_the_stop_time(tmp_path, test_fmus, monkeypatch, stop, step, k,
                                                              algorithm, options):
    # clock.y is the FMU's own t + h after each of its doSteps; before, k = 2 ended at 50.00000000000001, and k = 3
    # over 10 steps took its last step from 0.9 to 1.2 (and never showed it): FMI 2.0 forbids a step past the
    # stop time given to fmi2SetupExperiment
    options = dict(options)
    if options.pop("pure_python", False):
        from master import accel
        monkeypatch.setenv(accel.ENV, "1")
    r = master.run(_multirate_clock(tmp_path, test_fmus, stop, step, k), output=None, record=["*"],
                   algorithm=algorithm, **options)
    df = r.frame
    n = int(round(stop / step))
    assert len(df) == n + 1 and df["time"].iloc[-1] == stop
    y = df["clock.y"].to_numpy()
    assert y.max() == stop and y[-1] == stop                 # its last macro step ends there, and is shown
    macro_ends = [min(m * k, n) for m in range(1, -(-n // k) + 1)]
    # its outputs change where its macro steps end (published there), and only there
    changes = [j for j in range(1, n + 1) if y[j] != y[j - 1]]
    assert changes == macro_ends
    np.testing.assert_allclose(y[macro_ends], np.array(macro_ends) * step, rtol=1e-12)


ROLLBACK = [("iterative", {}), ("iterative", {"coupling_interpolation": 1}), ("adaptive", {"step_rtol": 1e-2}),
            ("gauss-seidel", {"gs_interpolation": 1}), ("jacobi", {})]


@pytest.mark.parametrize("algorithm,extra", ROLLBACK, ids=[f"{a}-{'-'.join(o) or 'default'}" for a, o in ROLLBACK])
def test_every_algorithm_ends_the_last_macro_step_at_the_stop_time(tmp_path, test_fmus, monkeypatch,
                                                                    algorithm, extra):
    # B on k = 3 over 500 steps of 0.1 s: its last macro step starts at n = 498 (49.800000000000004) and is cut
    # to 50 - that; each (t, h) of a doStep recorded through fast_ops (accelerators off: the reference step calls
    # them; adaptive always does)
    from master import accel
    monkeypatch.setenv(accel.ENV, "1")
    ends = {}
    fast_ops = Runtime.fast_ops

    def recording(self, i, setters=True):
        ops = list(fast_ops(self, i, setters))
        step = ops[2]
        ops[2] = lambda t, h: ends.setdefault(self.names[i], []).append(t + h) or step(t, h)
        return tuple(ops)

    monkeypatch.setattr(Runtime, "fast_ops", recording)
    r = master.run(_masses_ssp(tmp_path, test_fmus), output=None, algorithm=algorithm, step_multiples={"B": 3}, **extra)
    assert r.frame["time"].iloc[-1] == 50.0 and len(r.frame) == 501
    assert max(ends["B"]) == 50.0 and ends["B"][-1] == 50.0 and max(ends["A"]) == 50.0
    assert sorted(set(np.round(ends["B"], 9))) == [round(min(3 * m, 500) * 0.1, 9) for m in range(1, 168)]
