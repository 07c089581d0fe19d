"""Strategy C's decisions on the ground-station stream (uavstudy/mavlink): a pymavlink ground station on loopback
gets, from the vehicle that decided, a STATUSTEXT naming the UAV, the target and the other UAV for each takeover
(and give-way) the comm monitor wrote to events.csv, at NOTICE severity for a change of claims.

The scenario is the takeover of tests/uavstudy/test_comm_events.py: uav2 flies into a zone and uav1, having heard
it, takes over its target 1 about 5 s later."""
from __future__ import annotations

import time

import pandas as pd
import pytest
import yaml

pytest.importorskip("pymavlink")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as m  # noqa: E402

from master.execution import Execution  # noqa: E402
from uavstudy.build import build_scenario, default_fmu_dir  # noqa: E402
from uav_places import BASE, latlon  # noqa: E402
from loopback import free_port  # noqa: E402

FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]
pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")


def test_takeover_and_give_way_reach_the_ground_station_as_status_text(tmp_path):
    d = {"name": "coop_gcs", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2,
         "strategy": "C", "step": 0.1, "stop_time": 40.0, "seed": 5, "rules": "paper", "wind": {"probability": 0.0},
         "comm": {"range": 300.0, "period": 0.5, "latency": 0.0, "loss": 0.0},
         "targets": [latlon(0, 150), latlon(0, -100)],
         "zones": [{"name": "pen", "polygon": [latlon(-30, -60), latlon(30, -60), latlon(30, -40),
                                               latlon(-30, -40)]}]}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(d, sort_keys=False))
    ssp = build_scenario(tmp_path / "s.yaml", tmp_path / "s.ssp")
    port = free_port()
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
    got = []

    def drain(wait):
        end = time.monotonic() + wait
        while time.monotonic() < end:
            msg = gcs.recv_match(blocking=False)
            if msg is None:
                time.sleep(0.002)
            elif msg.get_type() == "STATUSTEXT":
                got.append(msg)

    ex = Execution(ssp, output=tmp_path / "run", mavlink=[f"udpout:127.0.0.1:{port}"])
    ex.initialize()
    while not ex.done:
        ex.simulate_until(ex.time + 2.0)
        drain(0.01)
    ex.close("completed")
    drain(0.5)
    gcs.close()
    ev = pd.read_csv(tmp_path / "run" / "events.csv")
    coop = ev[ev.type == "coop"]
    assert "takeover" in set(coop.event)                 # the scenario did what the test is about
    texts = [(t.get_srcSystem(), t.severity, t.text) for t in got]
    assert (1, m.MAV_SEVERITY_NOTICE, "uav1 took over target 1 of uav2") in texts
    # one status text per C event, from the vehicle that decided it
    for row in coop.itertuples():
        sysid = int(row.uav.removeprefix("uav"))
        assert sum(1 for s, _, text in texts if s == sysid and text == f"{row.uav} {row.detail.split(' (')[0]}") \
            == ((coop.uav == row.uav) & (coop.detail == row.detail)).sum()
