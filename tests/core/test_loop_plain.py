"""The plain step loop (Execution._plain_steps: no manipulator, no progress bar, no native loop) against the
general loop of Execution._steps, which a manipulator that does nothing forces: the same rows, events, doStep
counts and end, bit for bit, on a 4-UAV mission in which the UAV monitor takes two colliding UAVs out (the step
is rebuilt) and ends the run between two recorded rows (the recording then samples the end)."""
import json
from pathlib import Path

import pandas as pd

import master
from master import execution
from master.manipulators import Manipulator

SSP = Path(__file__).resolve().parents[2] / "ssp" / "paper_zones_4uav_A.ssp"
KW = dict(stop_time=100.0, step=0.1, record=["*"], record_interval=1.0)


class Nothing(Manipulator):
    """Changes nothing: only its presence sends the run down the general loop."""
    def before_step(self, n, t):
        pass


def _run(tmp_path, name, **kw):
    out = tmp_path / name
    res = master.run(SSP, output=out, **{**KW, **kw})
    meta = json.loads((out / "run.json").read_text())
    events = pd.read_csv(out / "events.csv") if (out / "events.csv").exists() else None
    return res.frame, events, meta


def test_plain_loop_equals_the_general_loop(tmp_path, monkeypatch):
    plain_calls = []
    orig = execution.Execution._plain_steps

    def spy(self, n, end, finite, check):
        plain_calls.append((n, end))
        return orig(self, n, end, finite, check)
    monkeypatch.setattr(execution.Execution, "_plain_steps", spy)
    a, ev_a, meta_a = _run(tmp_path, "plain")
    assert plain_calls, "the plain loop did not run"
    n_plain = len(plain_calls)
    b, ev_b, meta_b = _run(tmp_path, "general", manipulators=[Nothing()])
    assert len(plain_calls) == n_plain, "the general loop was not taken with a manipulator"

    assert (ev_a["type"] == "uav").sum() == 2          # a UAV-UAV contact: both UAVs taken out
    assert meta_a["ended_early"] == meta_b["ended_early"]
    assert meta_a["steps_done"] == meta_b["steps_done"] == 348     # the monitor's stop, not the stop time
    assert meta_a["fmu_calls"] == meta_b["fmu_calls"]
    assert meta_a["last_time"] == meta_b["last_time"]
    pd.testing.assert_frame_equal(ev_a, ev_b)
    assert a.equals(b)
    # a row every 10 steps and one at the end of the run (step 348 is not a multiple of 10)
    times = a["time"].tolist()
    assert times[:3] == [0.0, 1.0, 2.0]
    assert times[-2] == 34.0 and abs(times[-1] - 34.8) < 1e-9 and len(times) == 36


def test_the_plain_loop_stops_at_the_stop_time_with_a_last_row(tmp_path):
    """No early end: the recording's last row comes from ``n + 1 == steps`` (18 steps, a row every 4)."""
    a, _, meta = _run(tmp_path, "short", stop_time=1.8, record_interval=0.4)
    assert meta["steps_done"] == 18 and "ended_early" not in meta
    assert [round(t, 9) for t in a["time"]] == [0.0, 0.4, 0.8, 1.2, 1.6, 1.8]
