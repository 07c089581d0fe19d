"""A finished run of strategy C leaves nothing of itself behind in the process: the comm monitor's table of
running systems (which map.png asks for the links) kept each run's monitor, and through it the run's context,
buffers and plan, so a campaign worker flying thousands of C runs grew until the kernel killed it (two of the
cooperative campaign's 4160 runs died so, the worker at 12 and 18 GB)."""
import gc

import pytest
import yaml
from master.runner import run
from uavstudy.build import build_scenario, default_fmu_dir
from uavstudy.comm_monitor import CommMonitor
from uav_places import BASE, latlon

FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]


def _alive() -> int:
    gc.collect()
    return sum(isinstance(o, CommMonitor) for o in gc.get_objects())


@pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                    reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")
def test_a_finished_c_run_keeps_no_comm_monitor_alive(tmp_path):
    d = {"name": "lifetime", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2, "strategy": "C",
         "targets": [latlon(0, 60), latlon(0, -60)], "step": 0.5, "stop_time": 10.0, "seed": 1}
    path = tmp_path / "lifetime.yaml"
    path.write_text(yaml.safe_dump(d))
    ssp = build_scenario(path, tmp_path / "lifetime.ssp")
    before = _alive()
    for k in range(2):
        result = run(ssp, output=tmp_path / f"run{k}")
        assert result.metadata["outcome"] == "completed"
        del result
    assert _alive() == before
