"""Real ArduPilot SITL UAVs in lock-step with their doSteps run concurrently (``threads=2``,
master/algorithms/parallel.py): the run completes, every SITL UAV takes off, each on its own SITL instance, with
the firmware clock on the master's at every step (lock-step: the firmware sees the same frames whichever thread
answers them; docs/sitl.md, "Determinism").

The run is ``sitl_fleet`` (conftest.py): four SITL UAVs and a point-mass one stepped by two threads, shared with
test_sitl_vehicle.py and test_sitl_mission.py."""
from __future__ import annotations

import pytest
from test_sitl_vehicle import error_of, needs_sitl, sitl_pids


@needs_sitl
def test_lockstep_sitl_uavs_step_concurrently(sitl_fleet):
    res = sitl_fleet.result
    assert res.metadata["outcome"] == "completed", error_of(res)
    assert res.metadata["algorithm_info"]["threads"] == 2
    f = res.frame
    assert f["time"].iloc[-1] == pytest.approx(sitl_fleet.stop)
    vehicles = res.metadata["monitors"]["org.cosim-master.sitl-clock"]["vehicles"]
    assert len({vehicles[f"uav{k}_dyn"]["sitl_instance"] for k in range(1, 5)}) == 4
    for k in range(1, 5):
        assert f[f"uav{k}_dyn.z"].max() > 1.0, f"uav{k} did not take off"
        assert (f[f"uav{k}_dyn.slip"] == 0.0).all()      # lock-step: the firmware clock is the master's
    assert f["uav5_dyn.z"].max() > 1.0                    # the point-mass UAV flew beside them
    assert sitl_pids(sitl_fleet.under) == []
