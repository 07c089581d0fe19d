"""A one-UAV mission runs in libcosim (libcosimpy) with the same trajectory as ours under Jacobi.

The SSP is the one ``uavstudy.build.build_scenario`` writes, given to libcosim unchanged: no variant
was needed.  It contains String parameters (the strategy's ``strategy``, ``assignment``; the targets and zones are
indexed Integer/Real parameters since 2026-11-23, see uavsim/mission_encoding.py), Integer connectors (``cmd``, ``phase``, ``mission_state``), Boolean parameters (the wind's
``turbulence``/``gusts``), our settings and UAV-monitor annotations next to the OSP step annotation,
and pythonfmu FMUs (whose binaries libcosim instantiates without a resource location, see
``tests/peers/libcosim_runner.py``).  libcosim (libcosimpy 0.0.6 / libcosim 0.11.2) applies the
String, Integer and Real parameters (the mission and the seeded wind would differ otherwise), ignores
the foreign annotations and runs the mission.  Quick checks while writing this test, at step 0.5 s,
also bit-identical: a 2-UAV SSP (three FMU files each shared by two components) and a scenario with
``turbulence``/``gusts`` true (Boolean parameters applied: wind_z != 0).  What libcosim does not do is
what our annotations ask of *our* master: the UAV monitor (collisions, zone entries, mission outputs
such as summary.json) and the record settings; the stop time is given by the caller (``run_libcosim``
steps until it).

Comparison at every step: ``uav1_dyn.x/y/z``, ``uav1_bat.soc``, the strategy's ``cmd`` and
``mission_state`` (plus photo count and wind), reals to ATOL = 1e-9, integers exactly.  Wind is on
(probability 0.3, seed 3, 5 s decision intervals) so the seeded wind history is part of the check.

* step 0.5 s: libcosim's time is integer nanoseconds (0.5 s = 500 000 000 ns) and n * 0.5 is exact in
  binary, so both masters pass the same doStep arguments and the results are bit-identical
  (measured: 0 for every variable).
* step 0.1 s: libcosim passes fmi2DoStep the time t_n = n * 1e8 ns converted to double and the step
  ``to_double_duration(dt, t_n)`` = double(t_n+1) - double(t_n) (libcosim src/cosim/fmi/v2/fmu.cpp,
  slave_instance::do_step; src/cosim/time.hpp), i.e. 0.1 give or take a few ulps depending on n; we
  pass n * 0.1 and exactly 0.1.  The dynamics' sub-step dt / round(dt / 0.01) and the wind ramp
  (evaluated at t + dt) then differ in the last bits, so the trajectories differ by rounding only
  (measured: <= 3.6e-13 m in position, 1.1e-16 in soc, 4.3e-14 m/s in wind; integers identical; the
  same order of magnitude without wind).

The libcosim run happens in a child process: libcosim runs the pythonfmu binaries, which re-enter the
Python interpreter, and an exception driven through a pythonfmu 0.7 binary corrupts that interpreter;
in a child process a failure cannot take the test session with it.
"""
from __future__ import annotations

import functools
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from our_uav_runs import whole_free_1uav_mission
from peer_runs import Job

import master
from uavstudy.build import build_scenario, default_fmu_dir
from uav_places import BASE, latlon

TESTS = Path(__file__).resolve().parents[1]
FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu"]
ATOL = 1e-9
STOP = 100.0        # s: the mission (5 s preflight, 3 targets 40-57 m away, landing) ends at ~75 s

VARS = [("uav1_dyn", "x"), ("uav1_dyn", "y"), ("uav1_dyn", "z"), ("uav1_bat", "soc"), ("uav1_strat", "cmd"),
        ("uav1_strat", "mission_state"), ("uav1_strat", "photo_count"), ("uav1_dyn", "phase"),
        ("wind", "wind_x"), ("wind", "wind_level")]
INTEGERS = {"uav1_strat.cmd", "uav1_strat.mission_state", "uav1_strat.photo_count", "uav1_dyn.phase",
            "wind.wind_level"}

pytestmark = [
    pytest.mark.skipif(importlib.util.find_spec("libcosimpy") is None, reason="libcosimpy not installed"),
    pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                       reason="UAV FMUs not built (python fmu_sources/build_fmus.py)"),
]

_LIBCOSIM_SCRIPT = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
from peers.one_cpu import pin
pin()
from peers.libcosim_runner import run_libcosim
for ssp, step, stop, out, variables in json.loads(sys.argv[2]):
    run_libcosim(ssp, step, stop, [tuple(v) for v in variables]).to_parquet(out)
"""


def _run_libcosim_jobs(jobs) -> list[pd.DataFrame]:
    """libcosim runs of (ssp, step, stop, out parquet, variables), all in one child process (one interpreter and
    one libcosim load for all): one DataFrame per job."""
    spec = [[str(ssp), step, stop, str(out), [list(v) for v in variables]] for ssp, step, stop, out, variables in jobs]
    proc = subprocess.run([sys.executable, "-c", _LIBCOSIM_SCRIPT, str(TESTS), json.dumps(spec)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"libcosim run failed ({proc.returncode}):\n{proc.stderr[-3000:]}"
    return [pd.read_parquet(out) for _, _, _, out, _ in jobs]


def _run_libcosim_child(ssp: Path, step: float, stop: float, out: Path, variables=VARS) -> pd.DataFrame:
    return _run_libcosim_jobs([(ssp, step, stop, out, variables)])[0]


def _assert_same_values(ours: pd.DataFrame, theirs: pd.DataFrame, variables=VARS,
                        integers=INTEGERS) -> dict[str, float]:
    """Integers equal, reals within ATOL, at every step; the largest difference of each variable."""
    worst = {}
    for c, v in variables:
        key = f"{c}.{v}"
        a, b = ours[key].to_numpy(), theirs[key].to_numpy()
        if key in integers:
            assert np.array_equal(a.astype(int), b.astype(int)), key
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=ATOL, err_msg=key)
        worst[key] = float(np.max(np.abs(a.astype(float) - b.astype(float))))
    return worst


_BUILT: dict = {}


def _one_uav_ssp(tmp_path_factory) -> Path:
    """The one-UAV scenario's SSP, built once per session."""
    if "one_uav" in _BUILT:
        return _BUILT["one_uav"]
    tmp = tmp_path_factory.mktemp("libcosim_uav")

    scenario = {"name": "libcosim_one_uav", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 1,
                "strategy": "B", "targets": [latlon(0, 40), latlon(40, 40), latlon(40, 0)],
                "wind": {"probability": 0.3, "decision_interval": 5.0}, "seed": 3, "step": 0.5,
                "stop_time": STOP, "algorithm": "jacobi",
                "end_when_all_landed": False}     # libcosim runs to the stop time: so must ours
    y = tmp / "one_uav.yaml"
    y.write_text(yaml.safe_dump(scenario, sort_keys=False))
    _BUILT["one_uav"] = build_scenario(y, tmp / "one_uav.ssp")
    return _BUILT["one_uav"]


@pytest.fixture(scope="module")
def one_uav_ssp(tmp_path_factory) -> Path:
    return _one_uav_ssp(tmp_path_factory)


SHIPPED = TESTS.parent / "ssp" / "paper_free_1uav_B.ssp"
ZONES_4UAV = TESTS.parent / "ssp" / "paper_zones_4uav_B.ssp"
ZONES_STOP = 150.0


def _uav(name: str, k: int) -> str:
    """uav1's name for UAV k."""
    return name.replace("uav1_", f"uav{k}_")


ZONES_VARIABLES = [(_uav(c, k), v) for k in range(1, 5) for c, v in VARS if c != "wind"] + \
                  [(f"uav{k}_strat", "n_zones") for k in range(1, 5)]
ZONES_INTEGERS = {_uav(key, k) for k in range(1, 5) for key in INTEGERS} | \
                 {f"uav{k}_strat.n_zones" for k in range(1, 5)}


@functools.lru_cache(maxsize=None)
def _ours_shipped() -> pd.DataFrame:
    """Our run of the shipped mission; it ends when the UAV has landed, and its length is libcosim's stop."""
    return whole_free_1uav_mission([f"{c}.{v}" for c, v in VARS])


def _job(ssp: Path, step: float, stop: float, variables, integers=INTEGERS) -> Job:
    """libcosim steps until n * step = ``stop`` (tests/interop/peer_runs.py)."""
    n = int(round(stop / step))
    assert n * step == stop, (stop, step)
    return Job(str(ssp), step, n, [[c, v, "Integer" if f"{c}.{v}" in integers else "Real"] for c, v in variables])


def uav_peer_jobs(peer, tmp_path_factory) -> dict:
    """This module's libcosim runs ({key: Job}), run in the session's libcosim child with the other modules'
    (conftest.py)."""
    if peer != "libcosim":
        return {}
    one_uav = _one_uav_ssp(tmp_path_factory)
    jobs = {("one_uav", 0.5): _job(one_uav, 0.5, STOP, VARS), ("one_uav", 0.1): _job(one_uav, 0.1, STOP, VARS)}
    if SHIPPED.is_file():
        jobs["shipped"] = _job(SHIPPED, 0.1, (len(_ours_shipped()) - 1) * 0.1, VARS)
    if ZONES_4UAV.is_file():
        jobs["zones_4uav"] = _job(ZONES_4UAV, 0.1, ZONES_STOP, ZONES_VARIABLES, ZONES_INTEGERS)
    return jobs


@pytest.fixture(scope="module")
def libcosim_runs(request, uav_peer_runs) -> dict:
    """Every libcosim run of this module, in the session's libcosim child: {key: DataFrame}."""
    return uav_peer_runs("libcosim", request.module)


@pytest.mark.parametrize("step", [0.5, 0.1])
def test_one_uav_mission_same_trajectory_in_libcosim(libcosim_runs, one_uav_ssp, step, record_property):
    n = int(round(STOP / step))
    theirs = libcosim_runs[("one_uav", step)]
    ours = master.run(one_uav_ssp, output=None, algorithm="jacobi", step=step, record_interval=step,
                      record=[f"{c}.{v}" for c, v in VARS]).frame
    assert len(ours) == len(theirs) == n + 1
    # times: ours t = n * h, libcosim's integer nanoseconds / 1e9
    np.testing.assert_allclose(ours["time"], theirs["time"], rtol=0, atol=1e-12)
    if step == 0.5:
        assert np.array_equal(ours["time"].to_numpy(), theirs["time"].to_numpy())

    record_property("max_abs_diff", json.dumps(_assert_same_values(ours, theirs)))

    # the mission really flew: three photos, back on the pad, wind blew in some intervals
    last = theirs.iloc[-1]
    assert last["uav1_strat.photo_count"] == 3 and last["uav1_strat.mission_state"] == 7    # landed at base
    assert theirs["uav1_dyn.z"].max() > 19.0 and theirs["uav1_bat.soc"].iloc[-1] < 0.95
    assert (theirs["wind.wind_level"] > 0).any() and theirs["wind.wind_x"].abs().max() > 1.0


@pytest.mark.skipif(not SHIPPED.is_file(), reason=f"{SHIPPED.name} not built (python ssp/build_all.py)")
def test_shipped_mission_same_in_libcosim(libcosim_runs, record_property):
    """ssp/paper_free_1uav_B.ssp (24 targets, its 0.1 s step, Jacobi) in libcosim, unchanged, until our run
    ends (the UAV has landed): same photos and states, positions equal to rounding (libcosim's 0.1 s steps
    differ from ours by ulps, see the module docstring; measured 2026-11-23 over the 825 s mission: 5.6e-11 m
    in x, 5.5e-11 m in y, 3.9e-13 m in z, 7e-15 in soc; integers identical)."""
    ours = _ours_shipped()
    theirs = libcosim_runs["shipped"]
    assert len(theirs) == len(ours)
    record_property("max_abs_diff", json.dumps(_assert_same_values(ours, theirs)))
    last = theirs.iloc[-1]
    assert last["uav1_strat.photo_count"] == 24 and last["uav1_strat.mission_state"] == 7     # landed at base


@pytest.mark.skipif(not ZONES_4UAV.is_file(), reason=f"{ZONES_4UAV.name} not built (python ssp/build_all.py)")
def test_shipped_4uav_zones_mission_same_in_libcosim(libcosim_runs, record_property):
    """ssp/paper_zones_4uav_B.ssp (four UAVs, 24 targets, four no-fly zones as indexed Real parameters, its 0.1 s
    step, Jacobi, no wind) in libcosim, unchanged, over its first 150 s (kept short for the suite: takeoff,
    transit around the zones, which bend every path from t = 16.1 s, and the first photos). Integers identical;
    positions to rounding, from libcosim's 0.1 s steps (module docstring; measured 2026-11-23 over the 150 s:
    <= 1.0e-11 m in position, 2.2e-16 in soc), within ATOL."""
    step = 0.1
    ours = master.run(ZONES_4UAV, output=None, algorithm="jacobi", step=step, stop_time=ZONES_STOP,
                      record_interval=step, record=[f"{c}.{v}" for c, v in ZONES_VARIABLES]).frame
    theirs = libcosim_runs["zones_4uav"]
    assert len(theirs) == len(ours) == int(round(ZONES_STOP / step)) + 1
    record_property("max_abs_diff",
                    json.dumps(_assert_same_values(ours, theirs, ZONES_VARIABLES, ZONES_INTEGERS)))
    # libcosim applied the zones: each strategy has the SSP's four; and the fleet flew to its first photos
    for k in range(1, 5):
        assert set(theirs[f"uav{k}_strat.n_zones"]) == {4}
        assert theirs[f"uav{k}_strat.photo_count"].iloc[-1] >= 1 and theirs[f"uav{k}_dyn.z"].max() > 19.0
