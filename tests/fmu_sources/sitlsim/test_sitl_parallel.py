"""Two real ArduPilot SITL UAVs in lock-step with their doSteps run concurrently (``threads=2``,
master/algorithms/parallel.py): the run completes, both UAVs take off, each on its own SITL instance, and the
per-UAV results are those of the sequential run (lock-step: the firmware sees the same frames whichever thread
answers them; docs/sitl.md, "Determinism")."""
from __future__ import annotations

import pytest
from sitlveh_helpers import real_binary
from test_sitl_vehicle import error_of, run, scenario, sitl_pids

BINARY, WHY = real_binary()


@pytest.mark.skipif(BINARY is None, reason=f"{WHY}: the real-SITL tests are skipped")
def test_two_lockstep_sitl_uavs_step_concurrently(tmp_path, monkeypatch):
    monkeypatch.setenv("ARDUPILOT_SITL", BINARY)
    ssp = scenario(tmp_path, n_uavs=2, targets=((30.0, 0.0), (0.0, 30.0)), stop=6.0, name="two")
    res = run(ssp, tmp_path / "par", threads=2)
    assert res.metadata["outcome"] == "completed", error_of(res)
    assert res.metadata["algorithm_info"]["threads"] == 2
    f = res.frame
    assert f["time"].iloc[-1] == pytest.approx(6.0)
    vehicles = res.metadata["monitors"]["org.cosim-master.sitl-clock"]["vehicles"]
    assert len({vehicles[f"uav{k}_dyn"]["sitl_instance"] for k in (1, 2)}) == 2
    for k in (1, 2):
        assert f[f"uav{k}_dyn.z"].max() > 1.0, f"uav{k} did not take off"
        assert (f[f"uav{k}_dyn.slip"] == 0.0).all()      # lock-step: the firmware clock is the master's
    assert sitl_pids(tmp_path) == []
