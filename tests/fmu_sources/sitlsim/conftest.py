"""Real-SITL runs that several tests assert on, each run once per session.

A SITL vehicle costs its get-ready first (~42 s of vehicle time answered frame by frame in lock-step, about 2 s
of CPU of firmware and physics before t = 0, ../shared/sitl/README.md), so the tests that look at different
aspects of the same kind of flight share one:

* ``sitl_fleet``: four lock-step SITL UAVs and one point-mass UAV in one process, their doSteps run by two
  threads (test_sitl_vehicle.py: four SITLs on distinct instances; test_sitl_parallel.py: concurrent lock-step
  steps; test_sitl_mission.py: the clock facts in run.json, which name the SITL vehicles only).
* ``paced_mission``: the short one-UAV mission flown paced (test_sitl_vehicle.py: flown, with its slip;
  test_sitl_mission.py: run.json's clock facts of a paced vehicle).

Both skip with the reason where the firmware is absent ($ARDUPILOT_SITL, else ../shared/sitl/arducopter).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
from sitlveh_helpers import real_binary

FLEET_STOP = 8.0          # s of mission: every SITL UAV has taken off (above 2 m) by then
FLEET_TARGETS = ((40.0, 0.0), (0.0, 40.0), (-40.0, 0.0), (0.0, -40.0), (30.0, 30.0))
FLEET_VEHICLES = ["sitl", "sitl", "sitl", "sitl", "point_mass"]
PACED_STOP = 120.0        # s: the mission ends (landed) well before


@dataclass
class SharedRun:
    out: Path            # the run's output folder
    under: Path          # the folder every file of the run (SSP, output, SITL folders) lies under
    result: object       # master's RunResult
    stop: float          # the scenario's stop time (s)


def _binary_or_skip() -> str:
    binary, why = real_binary()
    if binary is None:
        pytest.skip(f"{why}: the real-SITL tests are skipped")
    return binary


def _shared_run(tmp_path_factory, folder: str, out: str, stop: float, run_options: dict | None = None,
                **scenario) -> SharedRun:
    """One real-SITL run of ``test_sitl_vehicle.scenario(**scenario)`` (``run_options`` to master.run), for every
    test that asserts on it."""
    binary = _binary_or_skip()
    from test_sitl_vehicle import run, scenario as build
    under = tmp_path_factory.mktemp(folder)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ARDUPILOT_SITL", binary)
        result = run(build(under, stop=stop, **scenario), under / out, **(run_options or {}))
    return SharedRun(under / out, under, result, stop)


@pytest.fixture(scope="session")
def sitl_fleet(tmp_path_factory):
    return _shared_run(tmp_path_factory, "sitl_fleet", "fleet", FLEET_STOP, {"threads": 2}, n_uavs=len(FLEET_VEHICLES),
                       targets=FLEET_TARGETS, name="fleet", vehicle=FLEET_VEHICLES)


@pytest.fixture(scope="session")
def paced_mission(tmp_path_factory):
    return _shared_run(tmp_path_factory, "sitl_paced", "p", PACED_STOP, coupling="paced")
