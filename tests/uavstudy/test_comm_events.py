"""Strategy C's events in events.csv (uavstudy/comm_monitor.py), on whole runs of built SSPs whose timing follows by
hand from the scenario and the channel's rules (docs/cooperative.md):

* a takeover: uav2's only target lies inside a restricted zone, so uav2 is removed when it enters the zone; the
  channel (period 0.5 s, no latency, no loss) delivered uav2's last message at most one period + one step before
  the removal, and uav1 counts uav2 as lost ``lost_timeout`` (5 s) after that message: the takeover of uav2's
  target is at the removal + 5 s, less at most 0.6 s;
* a give-way: two UAVs on the north and south pads of the ring (8 m apart) with their targets beyond each other's
  pad: once their first legs start (the monitor's ``transit`` events), the first message gives the higher index
  (uav2) the conflict: it gives way to uav1 within one period (+ one step) of the later transit, 8 m from it;
* nothing of the sort without a channel.
"""
from pathlib import Path

import pandas as pd
import pytest
import yaml
from master.runner import run
from uavsim.geodesy import geodetic_from_enu
from uavstudy.build import build_scenario, default_fmu_dir
from uavstudy.comm_monitor import COMM_TYPE, EVENT_TYPE
from uav_places import BASE, latlon

FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]
pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")
PERIOD, STEP, LOST_TIMEOUT = 0.5, 0.1, 5.0


def run_yaml(tmp_path: Path, name: str, **over):
    d = {"name": name, "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2, "strategy": "C",
         "step": STEP, "stop_time": 120.0, "seed": 5,
         "comm": {"range": 300.0, "period": PERIOD, "latency": 0.0, "loss": 0.0}}
    d.update(over)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    return run(build_scenario(path, tmp_path / f"{name}.ssp"), output=tmp_path / name)


def events(result) -> pd.DataFrame:
    return pd.read_csv(result.output_dir / "events.csv")


# uav1 (north pad) gets the northern target, uav2 (south pad) the southern one, behind a zone across its path
# 40 to 60 m south of the base; under the paper's rules (2 m detection, no planning) uav2 flies into it; uav1's
# target is 150 m north, so uav1 is still flying to it when uav2 is removed
TAKEOVER = dict(targets=[latlon(0, 150), latlon(0, -100)], rules="paper", wind={"probability": 0.0},
                zones=[{"name": "pen", "polygon": [latlon(-30, -60), latlon(30, -60), latlon(30, -40),
                                                    latlon(-30, -40)]}])


def test_takeover_event_when_the_lost_uav_should_have_been_heard(tmp_path):
    res = run_yaml(tmp_path, "takeover", **TAKEOVER)
    ev = events(res)
    removal = ev[(ev.type == "zone") & (ev.uav == "uav2")]
    assert len(removal) == 1
    t_r = float(removal.time.iloc[0])
    coop = ev[ev.type == EVENT_TYPE]
    take = coop[coop.event == "takeover"]
    assert len(take) == 1
    row = take.iloc[0]
    assert (row.uav, row.other) == ("uav1", "uav2")
    assert row.detail.startswith("took over target 1 of uav2 (")     # the southern target, global index 1
    assert t_r + LOST_TIMEOUT - PERIOD - STEP - 1e-6 <= row.time <= t_r + LOST_TIMEOUT + 1e-6
    # where uav1 was then: its recorded track (1 s rows) within a second's flight of the event's position
    traj = pd.read_csv(res.output_dir / "trajectory.csv")
    near = traj[(traj.uav == "uav1") & ((traj.time - row.time).abs() <= 0.5 + 1e-9)]
    assert ((near.x - row.x) ** 2 + (near.y - row.y) ** 2).min() ** 0.5 <= 10.0 * 1.0
    lat, lon, _ = geodetic_from_enu(row.x, row.y, row.z, *BASE)
    assert (row.lat, row.lon) == pytest.approx((float(lat), float(lon)), abs=1e-9)
    # the takeover flew: uav1 photographed its own target, then turned for uav2's and met the same zone on the way
    comm = res.metadata["monitors"][COMM_TYPE]
    assert comm["uavs"]["uav1"]["takeovers"] == 1
    photos = pd.read_csv(res.output_dir / "photos.csv")
    assert list(photos[photos.uav == "uav1"].target) == [0]
    assert list(ev[(ev.type == "zone") & (ev.uav == "uav1")].time > row.time) == [True]
    # the links on map.png are those of the takeover's moment: uav1 no longer hears the removed uav2
    assert comm["links"]["why"] == "takeover" and comm["links"]["time"] == row.time
    assert ["uav1", "uav2"] not in comm["links"]["links"]


def test_no_takeover_event_without_a_channel(tmp_path):
    res = run_yaml(tmp_path, "silent", comm={"mode": "none"}, **TAKEOVER)
    ev = events(res)
    assert (ev.type == "zone").sum() == 1
    assert (ev.type == EVENT_TYPE).sum() == 0
    assert "links" not in res.metadata["monitors"][COMM_TYPE]


# north pad (0, 4) flies to the target 250 m south, south pad (0, -4) to the one 250 m north: head-on at once
HEAD_ON = dict(targets=[latlon(0, -250), latlon(0, 250)])


def test_give_way_event_when_the_first_legs_cross(tmp_path):
    res = run_yaml(tmp_path, "headon", **HEAD_ON)
    ev = events(res)
    transit = ev[(ev.type == "mission") & (ev.event == "transit")]
    start = float(transit.time.max())
    coop = ev[ev.type == EVENT_TYPE]
    assert set(coop.uav) == {"uav2"} and set(coop.other) == {"uav1"}     # the lower index has the right of way
    first = coop.iloc[0]
    assert first.event == "give_way"
    assert start <= first.time <= start + PERIOD + STEP + 1e-6
    assert first.distance == pytest.approx(8.0, abs=0.5)               # still about at their pads
    # it ends, and each start has its end after it
    kinds = list(coop.event)
    assert kinds[0::2] == ["give_way"] * len(kinds[0::2]) and kinds[1::2] == ["give_way_end"] * len(kinds[1::2])
    assert len(kinds) % 2 == 0
    assert res.metadata["monitors"][COMM_TYPE]["uavs"]["uav2"]["give_ways"] == len(kinds) // 2
    assert (ev[ev.type == "uav"]).empty


def test_an_ssp_built_before_cs_event_outputs_still_runs_without_events():
    """A strategy FMU without the event outputs (an SSP built before them): the monitor keeps its counters and
    links and writes no events, instead of refusing the run."""
    from types import SimpleNamespace

    from master.errors import ScenarioError
    from uavstudy.comm_monitor import WATCHED, CommMonitor, comm_annotation

    class OldPlan:
        params, model = [], SimpleNamespace(annotations={})

        def var(self, q):
            if q.split(".")[-1] in WATCHED[2:]:
                raise ScenarioError(f"component {q.split('.')[0]!r} has no variable {q.split('.')[-1]!r}")
            return SimpleNamespace(type="Integer")

    mon = CommMonitor(comm_annotation("channel", {"uav1": "uav1_strat", "uav2": "uav2_strat"}), OldPlan(), "old.ssp")
    assert mon.watched == ()
    names = mon.required_variables()
    assert "uav1_strat.takeovers" in names and "channel.uav2_m4_sender" in names
    assert not any(n.endswith((".give_way_to", ".taken0", ".dropped_to")) for n in names)
