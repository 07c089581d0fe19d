"""Strategy C's SSP (two UAVs, the channel FMU, the head-on departure from the take-off ring of
tests/uavstudy/test_comm.py) runs in libcosim unchanged and flies as in our master: the channel is an ordinary
FMU that another importer steps (a network simulator's FMU with the same ports could take its place).

At a 0.5 s step both masters pass the same doStep arguments (tests/interop/test_uav_libcosim.py), so the runs
agree to rounding; checked at every step: positions, states, the message counters, and the give-way altitude."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
import yaml

import master
from uavstudy.build import build_scenario, default_fmu_dir
from uavsim.geodesy import geodetic_from_enu

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_uav_libcosim import _assert_same_values, _run_libcosim_child  # noqa: E402

BASE = (-7.275, -35.965, 540.0)
STOP, STEP = 40.0, 0.5
FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]
pytestmark = [
    pytest.mark.skipif(importlib.util.find_spec("libcosimpy") is None, reason="libcosimpy not installed"),
    pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                       reason="UAV FMUs not built (python fmu_sources/build_fmus.py)"),
]
VARIABLES = [(f"uav{k}_dyn", v) for k in (1, 2) for v in ("x", "y", "z")] + \
            [(f"uav{k}_strat", v) for k in (1, 2) for v in ("mission_state", "give_ways", "sp_z")] + \
            [("channel", "messages_sent"), ("channel", "messages_received"), ("channel", "near_misses")]
INTEGERS = {f"uav{k}_strat.{v}" for k in (1, 2) for v in ("mission_state", "give_ways")} | \
           {"channel.messages_sent", "channel.messages_received", "channel.near_misses"}


def _latlon(e, n):
    lat, lon, _ = geodetic_from_enu(e, n, 0.0, *BASE)
    return [round(float(lat), 8), round(float(lon), 8)]


def test_strategy_c_with_its_channel_same_in_libcosim(tmp_path):
    scenario = {"name": "libcosim_c", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2,
                "strategy": "C", "targets": [_latlon(0, -250), _latlon(0, 250)], "seed": 3, "step": STEP,
                "stop_time": STOP, "algorithm": "jacobi", "end_when_all_landed": False,
                "comm": {"range": 300.0, "period": 0.5, "latency": 0.0}}
    y = tmp_path / "c.yaml"
    y.write_text(yaml.safe_dump(scenario, sort_keys=False))
    ssp = build_scenario(y, tmp_path / "c.ssp")
    ours = master.run(ssp, output=None, algorithm="jacobi", step=STEP, record_interval=STEP,
                      record=[f"{c}.{v}" for c, v in VARIABLES]).frame
    theirs = _run_libcosim_child(ssp, STEP, STOP, tmp_path / "libcosim.parquet", VARIABLES)
    assert len(ours) == len(theirs) == int(round(STOP / STEP)) + 1
    _assert_same_values(ours, theirs, VARIABLES, INTEGERS)
    last = theirs.iloc[-1]
    assert last["channel.messages_received"] > 0 and last["uav2_strat.give_ways"] >= 1
    assert theirs["uav2_strat.sp_z"].max() > theirs["uav1_strat.sp_z"].max()      # uav2 climbed out of the way
