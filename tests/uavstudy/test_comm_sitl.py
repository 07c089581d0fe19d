"""Strategy C steering real ArduCopter SITL vehicles ($ARDUPILOT_SITL, else ../shared/sitl/arducopter; skipped with
the reason when absent), as the A/B SITL tests do (tests/fmu_sources/sitlsim/test_sitl_vehicle.py).

Two SITL UAVs on the north and south pads of the ring (8 m apart), each with its target 40 m beyond the other's
pad: their first legs run head-on through each other.  Under C the channel carries their messages (in lock-step,
so deterministic), uav2 (the higher index) gives way to uav1 by climbing a layer (5 m above the 5 m take-off
altitude), which the firmware flies in GUIDED, and both finish without a collision."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from sitlveh_helpers import lean_sitl, real_binary

import master
from uavsim.geodesy import EnuFrame
from uavstudy.build import build_ssp
from uavstudy.comm_monitor import COMM_TYPE
from uavstudy.scenario import CommConfig, SitlOptions, UavScenario

BASE = (-7.275, -35.965, 540.0)
BINARY, WHY = real_binary()
TAKEOFF, LAYER = 5.0, 5.0
# the firmware's fastest landing (2 m/s; default 0.5 m/s): the give-way is over by then, and the mission
# ends 14 s of two lock-step vehicles sooner (57.6 -> 43.6 s); at the test rates, headless (lean_sitl): what is
# asserted (the give-way, the climb, no collision) does not depend on the firmware's frame or loop rate
QUICK_LANDING = {"LAND_SPEED": 200.0}


@pytest.mark.skipif(BINARY is None, reason=f"{WHY}: the real-SITL tests are skipped")
def test_c_steers_two_sitl_vehicles_past_each_other(tmp_path, monkeypatch):
    monkeypatch.setenv("ARDUPILOT_SITL", BINARY)
    fr = EnuFrame(*BASE)
    targets = [fr.to_geodetic(x, y, 0.0)[:2] for x, y in ((0.0, -40.0), (0.0, 40.0))]
    scn = UavScenario(name="sitl_c", base=BASE, n_uavs=2, strategy="C", targets=targets, takeoff_altitude=TAKEOFF,
                      stop_time=90.0, seed=3, vehicle="sitl",
                      sitl=SitlOptions(coupling="lockstep", speedup=80.0, **lean_sitl(**QUICK_LANDING)),
                      comm=CommConfig(range=300.0, period=0.5, latency=0.0, loss=0.0))
    ssp = build_ssp(scn, tmp_path / "sitl_c.ssp")
    res = master.run(ssp, output=tmp_path / "out", raise_on_error=False, write_csv=False)
    assert res.metadata["outcome"] == "completed", res.metadata.get("error")
    out = Path(tmp_path / "out")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["total"]["uav_collisions"] == 0
    assert {u["uav"]: u["outcome"] for u in summary["uavs"]} == {"uav1": "success", "uav2": "success"}
    comm = res.metadata["monitors"][COMM_TYPE]
    assert comm["messages"]["received"] > 0
    assert comm["uavs"]["uav2"]["give_ways"] >= 1 and comm["uavs"]["uav1"]["give_ways"] == 0
    ev = pd.read_csv(out / "events.csv")
    give = ev[(ev.type == "coop") & (ev.event == "give_way")]
    assert set(give.uav) == {"uav2"} and set(give.other) == {"uav1"}
    # the firmware flew the climb: uav2 went a layer above the take-off altitude, uav1 did not
    f = res.frame
    assert f["uav2_dyn.z"].max() > TAKEOFF + LAYER - 1.5
    assert f["uav1_dyn.z"].max() < TAKEOFF + 1.5
