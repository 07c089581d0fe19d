"""The shipped missions ssp/paper_free_1uav_B.ssp and ssp/paper_zones_4uav_B.ssp run in Ecos (ecospy) as in
cosim-master (Jacobi).

The SSP is given to Ecos unchanged; Ecos applies its parameters when ``init`` names the parameter set that
every component's binding carries (``uavstudy.build.PARAMETER_SET``, see tests/peers/ecos_runner.py).
Before that (one set name per component) Ecos applied no parameter at all: the UAV had no targets, took off
and landed at once.  Both masters step all components from the previous step's outputs (Jacobi), at the
SSP's 0.1 s step, until cosim-master's run ends (the fleet has landed).

Bit-identical, measured (2026-11-23, ecospy 0.7.2: max difference 0 in x, y, z and soc over all 8251
communication points), although Ecos's clock is a sum (t_{n+1} = t_n + h: t_61 = 6.099999999999994 where we
compute n * h = 6.1): Ecos passes fmi2DoStep exactly h, the models advance on h (the dynamics' preflight
check counts elapsed step sizes, with a 1e-9 s tolerance) and the scenario has no wind (the only model whose
output depends on t itself).  Only the photo *times* carry t, so they differ by the clock's rounding (not
compared).  Integers (photo count, photographed targets in order, mission state) are compared exactly.

The four-UAV mission with no-fly zones (13 components: wind and three per UAV; zones given as indexed Real
parameters) is compared over its first 150 s, so that the test stays short: takeoff, transit around the zones
(they bend every UAV's path from t = 16.1 s: measured, with n_zones = 0 the paths part by up to 90 m by 200 s),
and the first photos. No wind either, so the same holds: bit-identical, measured (2026-11-23, ecospy 0.7.2:
max difference 0 over 1501 communication points for every position, state of charge and integer).
"""
from __future__ import annotations

import functools
import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from our_uav_runs import whole_free_1uav_mission
from peer_runs import Job

import master
from uavstudy.build import PARAMETER_SET

TESTS = Path(__file__).resolve().parents[1]
SSP = TESTS.parent / "ssp" / "paper_free_1uav_B.ssp"
ZONES_4UAV = TESTS.parent / "ssp" / "paper_zones_4uav_B.ssp"
STEP = 0.1
VARIABLES = [("uav1_dyn", "x", "Real"), ("uav1_dyn", "y", "Real"), ("uav1_dyn", "z", "Real"),
             ("uav1_bat", "soc", "Real"), ("uav1_strat", "photo_count", "Integer"),
             ("uav1_strat", "last_photo_target", "Integer"), ("uav1_strat", "mission_state", "Integer")]
REALS = ["uav1_dyn.x", "uav1_dyn.y", "uav1_dyn.z", "uav1_bat.soc"]
INTEGERS = ["uav1_strat.photo_count", "uav1_strat.last_photo_target", "uav1_strat.mission_state"]

pytestmark = [
    pytest.mark.skipif(importlib.util.find_spec("ecospy") is None, reason="ecospy not installed"),
    pytest.mark.skipif(not SSP.is_file(), reason=f"{SSP.name} not built (python ssp/build_all.py)"),
]

@functools.lru_cache(maxsize=None)
def _ours() -> dict:
    """Our runs of both missions: {name: frame}."""
    ours = {"free_1uav": whole_free_1uav_mission([f"{c}.{v}" for c, v, _ in VARIABLES])}
    if ZONES_4UAV.is_file():
        ours["zones_4uav"] = master.run(ZONES_4UAV, output=None, algorithm="jacobi", step=STEP,
                                        stop_time=ZONES_STOP, record_interval=STEP,
                                        record=[f"{c}.{v}" for c, v, _ in ZONES_VARIABLES]).frame
    return ours


def uav_peer_jobs(peer, tmp_path_factory) -> dict:
    """This module's Ecos runs, as long as ours ({name: Job}), run in the session's Ecos child with the other
    modules' (conftest.py): it runs the pythonfmu binaries, which re-enter the interpreter, and a failure there
    must not take the test session with it."""
    if peer != "ecos":
        return {}
    variables = {"free_1uav": VARIABLES, "zones_4uav": ZONES_VARIABLES}
    return {name: Job(str({"free_1uav": SSP, "zones_4uav": ZONES_4UAV}[name]), STEP, len(frame) - 1,
                      [list(v) for v in variables[name]], options={"parameter_set": PARAMETER_SET})
            for name, frame in _ours().items()}


@pytest.fixture(scope="module")
def runs(request, uav_peer_runs):
    """Ours and Ecos's runs of both missions: {name: (ours, theirs)}."""
    theirs = uav_peer_runs("ecos", request.module)
    return {name: (ours, theirs[name]) for name, ours in _ours().items()}


def _photo_order(frame: pd.DataFrame) -> list[int]:
    """Global target indices in the order they were photographed."""
    got = frame["uav1_strat.last_photo_target"].to_numpy()
    return [int(k) for k in got[np.flatnonzero(np.diff(got, prepend=-1))] if k >= 0]


def test_paper_free_1uav_B_same_mission_in_ecos(runs, record_property):
    ours, theirs = runs["free_1uav"]
    assert len(theirs) == len(ours)
    np.testing.assert_allclose(theirs["time"], ours["time"], rtol=0, atol=1e-9)     # Ecos's summed clock
    diff = {k: float(np.max(np.abs(ours[k].to_numpy() - theirs[k].to_numpy()))) for k in REALS}
    record_property("max_abs_diff", json.dumps(diff))
    last = theirs.iloc[-1]
    # the mission really flew in Ecos: all 24 targets photographed, landed on the base
    assert last["uav1_strat.photo_count"] == 24 and last["uav1_strat.mission_state"] == 7
    assert sorted(_photo_order(theirs)) == list(range(24))
    for k in INTEGERS:
        assert np.array_equal(ours[k].to_numpy(), theirs[k].to_numpy()), k
    assert diff == dict.fromkeys(REALS, 0.0), f"not bit-identical: {diff}"


# -- four UAVs, no-fly zones ------------------------------------------------------------------------------------
ZONES_STOP = 150.0
UAVS = range(1, 5)


def _uav(name: str, k: int) -> str:
    """uav1's name for UAV k."""
    return name.replace("uav1_", f"uav{k}_")


ZONES_VARIABLES = [(_uav(c, k), v, t) for k in UAVS for c, v, t in VARIABLES] + \
                  [(f"uav{k}_strat", "n_zones", "Integer") for k in UAVS]


@pytest.mark.skipif(not ZONES_4UAV.is_file(), reason=f"{ZONES_4UAV.name} not built (python ssp/build_all.py)")
def test_paper_zones_4uav_B_same_mission_in_ecos(runs, record_property):
    ours, theirs = runs["zones_4uav"]
    assert len(theirs) == len(ours) == int(round(ZONES_STOP / STEP)) + 1
    np.testing.assert_allclose(theirs["time"], ours["time"], rtol=0, atol=1e-9)
    # Ecos applied the zones (the shared parameter set): each strategy has the SSP's four
    for k in UAVS:
        assert set(theirs[f"uav{k}_strat.n_zones"]) == {4}
    reals = [_uav(c, k) for k in UAVS for c in REALS]
    diff = {key: float(np.max(np.abs(ours[key].to_numpy() - theirs[key].to_numpy()))) for key in reals}
    record_property("max_abs_diff", json.dumps(diff))
    for key in [_uav(c, k) for k in UAVS for c in INTEGERS]:
        assert np.array_equal(ours[key].to_numpy(), theirs[key].to_numpy()), key
    # the window saw the fleet take off, cross to its areas and take its first photos
    last = theirs.iloc[-1]
    assert all(last[f"uav{k}_strat.photo_count"] >= 1 for k in UAVS)
    assert all(theirs[f"uav{k}_dyn.z"].max() > 19.0 for k in UAVS)
    assert diff == dict.fromkeys(reals, 0.0), f"not bit-identical: {diff}"
