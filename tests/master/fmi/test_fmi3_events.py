"""FMI 3.0 co-simulation with event mode and early return (master/fmi/fmi3.py).

The C test FMU Ball (tests/fmus_c/Ball.c) integrates a bouncing ball exactly between bounces, so that each
bounce is a state event at its exact time inside a communication step. It offers event mode and early
return; built with its event-mode framework, it checks the importer's side: a reported event must be handled
in Event Mode (fmi3UpdateDiscreteStates) before the next fmi3DoStep, and it counts the passes the importer asked
for. The expectations are the closed form of the bouncing ball, computed here: the first bounce at
t1 = sqrt(2 h0 / g) with rebound speed v1 = e g t1, then t(k+1) = t(k) + 2 v(k) / g and v(k+1) = e v(k); in
between h = v(k) (t - t(k)) - g (t - t(k))^2 / 2.

The Reference FMUs that offer event mode (BouncingBall, Stair) are checked against their own reference results
and their event counts: every BouncingBall bounce and every Stair count is an event the master handled. Roberts
declares event mode but refuses it when instantiated: it runs without.
"""
import json
import math
import re

import numpy as np
import pandas as pd
import pytest

import fmu_factory
import master
from master.ssp.writer import SspBuilder

G, E, H0 = 9.81, 0.5, 1.0
STEP, STOP = 0.1, 1.0


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return fmu_factory.build_c_fmu("Ball", tmp_path_factory.mktemp("ball"), fmi_version=3)


def _bounces(until: float) -> list[tuple[float, float]]:
    """(time, rebound speed) of every bounce before ``until``, from the closed form."""
    t, v, out = math.sqrt(2 * H0 / G), E * G * math.sqrt(2 * H0 / G), []
    while t < until:
        out.append((t, v))
        t, v = t + 2 * v / G, E * v
    return out


def _exact(t: float) -> tuple[float, float]:
    """Height and upward speed at t."""
    done = [b for b in _bounces(t) if b[0] <= t]
    if not done:
        return H0 - G * t * t / 2, -G * t
    tk, vk = done[-1]
    s = t - tk
    return vk * s - G * s * s / 2, vk - G * s


def _run(ssp, out):
    r = master.run(ssp, output=out, record=["b.*"])
    return r.frame, json.loads((out / "run.json").read_text())


def _ball_ssp(tmp_path, fmu, **params):
    b = SspBuilder("ball", stop=STOP, step=STEP)
    b.add_component("b", fmu, params={"g": G, "e": E, "h0": H0, **params})
    return b.write(tmp_path / "ball.ssp")


def test_events_inside_a_step_are_handled_at_their_time_by_the_master(tmp_path, ball):
    df, meta = _run(_ball_ssp(tmp_path, ball), tmp_path / "out")
    bounces = _bounces(STOP)
    assert [round(t, 4) for t, _ in bounces] == [0.4515, 0.9030]        # inside the steps to 0.5 and to 1.0
    # the grid is the master's: one row per communication point, whatever the events
    np.testing.assert_allclose(df["time"], np.arange(11) * STEP, rtol=0, atol=1e-12)
    for t, h, v in zip(df["time"], df["b.h"], df["b.v"]):
        want_h, want_v = _exact(t)
        assert h == pytest.approx(want_h, abs=1e-12) and v == pytest.approx(want_v, abs=1e-12), t
    # each bounce happened at its exact time (where fmi3DoStep returned early and the master entered Event Mode)
    at_end = df.iloc[-1]
    assert at_end["b.bounces"] == 2 and at_end["b.t_bounce"] == pytest.approx(bounces[1][0], abs=1e-12)
    assert df.loc[df["time"] > 0.5 - 1e-9, "b.t_bounce"].iloc[0] == pytest.approx(bounces[0][0], abs=1e-12)
    # the importer ran the event iterations: one pass after initialization (the FMU leaves it in Event Mode),
    # two per bounce (the bounce, then the check of max_bounces)
    assert list(df["b.importer_updates"]) == [1 + 2 * n for n in df["b.bounces"]]
    assert meta["solvers"]["b"] == {"event_mode": True, "early_return": True, "events": 2, "early_returns": 2}


def test_a_terminating_event_inside_a_step_ends_the_run_there(tmp_path, ball):
    # the ball asks to end the simulation at its first bounce (t1 = 0.4515, inside the step to 0.5)
    df, meta = _run(_ball_ssp(tmp_path, ball, max_bounces=1), tmp_path / "out")
    t1 = _bounces(STOP)[0][0]
    assert meta["outcome"] == "completed"
    assert meta["ended_early"] == {"time": pytest.approx(0.5), "reason": "component b asked to terminate the simulation"}
    last = df.iloc[-1]
    # the FMU stayed at the event: its own clock and state are those of t1 (rebound done), and the log says so
    assert last["b.time"] == pytest.approx(t1, abs=1e-12) and last["b.bounces"] == 1
    assert last["b.h"] == 0.0 and last["b.v"] == pytest.approx(E * G * t1, abs=1e-12)
    said = re.search(r"asked to terminate the simulation at t=(\S+), inside the communication step to 0.5",
                     (tmp_path / "out" / "fmu.log").read_text())
    assert said and float(said.group(1)) == pytest.approx(t1, abs=1e-12)


def test_fmu_without_event_mode_is_stepped_as_before(tmp_path, test_fmus):
    # c3:Integrator declares hasEventMode="false": instantiated without event mode (it refuses eventModeUsed)
    b = SspBuilder("i", stop=0.3, step=0.1)
    b.add_component("i", test_fmus["c3:Integrator"], params={"a": -1.0, "x0": 1.0})
    out = tmp_path / "out"
    master.run(b.write(tmp_path / "i.ssp"), output=out, record=["i.y"])
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "completed" and "i" not in meta.get("solvers", {})
    assert pd.read_csv(out / "results.csv")["i.y"].iloc[-1] == pytest.approx(0.9 ** 3, abs=1e-15)   # Euler


# -- the Reference FMUs that offer event mode ----------------------------------------------------------------
def _reference_run(tmp_path, reference_fmus, model):
    b = SspBuilder(model.lower(), stop=None, step=None)      # the FMU's default experiment
    b.add_component("m", reference_fmus / "fmi3" / f"{model}.fmu")
    out = tmp_path / "out"
    r = master.run(b.write(tmp_path / f"{model}.ssp"), output=out, record=["m.*"],
                   implementation={"m": "CoSimulation"})
    return r.frame, json.loads((out / "run.json").read_text()), pd.read_csv(reference_fmus / "ref" / f"{model}_out.csv")


def test_reference_bouncing_ball_events_handled_by_the_master(tmp_path, reference_fmus):
    df, meta, ref = _reference_run(tmp_path, reference_fmus, "BouncingBall")
    stats = meta["solvers"]["m"]
    assert stats["event_mode"] and stats["early_return"]
    # every bounce of the reference (v jumps from falling to rising) is an event the master handled
    rises = int(np.sum((ref["v"].to_numpy()[:-1] < 0) & (ref["v"].to_numpy()[1:] > 0)))
    assert rises >= 10 and stats["events"] >= rises
    # the FMU's forward Euler with the event at the internal step where h crosses 0 is the same sequence of
    # operations whether the FMU or the master runs the event update: the reference results, to rounding
    for col in ("h", "v"):
        got = np.interp(ref["time"], df["time"], df[f"m.{col}"])
        assert np.max(np.abs(got - ref[col])) <= 1e-12 * np.ptp(ref[col]), col


def test_reference_stair_time_events_handled_by_the_master(tmp_path, reference_fmus):
    # Stair counts at time events, each at a communication point (no early return offered): the master's event
    # iteration makes each count, and the one that reaches 10 asks to terminate at t = 9
    df, meta, ref = _reference_run(tmp_path, reference_fmus, "Stair")
    assert meta["solvers"]["m"] == {"event_mode": True, "early_return": False, "events": 9, "early_returns": 0}
    assert meta["ended_early"]["time"] == pytest.approx(9.0)
    np.testing.assert_allclose(df["time"], ref["time"], atol=1e-9)
    assert list(df["m.counter"]) == list(ref["counter"])


def test_an_fmu_that_refuses_the_event_mode_it_declares_runs_without(tmp_path, reference_fmus):
    # Roberts declares hasEventMode and mightReturnEarlyFromDoStep, but its binary refuses eventModeUsed ("Event
    # Mode is not supported."): instantiated again without event mode, it handles its events itself
    b = SspBuilder("roberts", stop=0.01, step=0.001)
    b.add_component("m", reference_fmus / "fmi3" / "Roberts.fmu")
    out = tmp_path / "out"
    master.run(b.write(tmp_path / "roberts.ssp"), output=out, record=["m.y1"], implementation={"m": "CoSimulation"})
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "completed"
    assert meta["solvers"]["m"] == {"event_mode": False, "early_return": True, "events": 0, "early_returns": 0}
    assert "declares hasEventMode but refused eventModeUsed" in (out / "fmu.log").read_text()
