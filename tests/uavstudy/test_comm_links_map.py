"""The links on map.png for strategy C (uavstudy/outputs.py ``link_segments``/``map_figure``, from the comm
monitor's who-heard-whom): the segments drawn are the pairs within radio range at the moment asked for
(``comm.links_at``), between where the UAVs were then; a removed UAV and self-links are left out, one-way links
are told apart."""
import math
from pathlib import Path

import pandas as pd
import pytest
import yaml
from master.execution import Execution
from uavstudy.build import build_scenario, default_fmu_dir
from uavstudy.comm_monitor import COMM_TYPE
from uavstudy.names import MONITOR_TYPE
from uavstudy.outputs import link_segments, map_figure, total_summary, uav_summaries
from uav_places import BASE, latlon

FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu", "UavChannel.fmu"]
RANGE, T = 300.0, 40.0


def test_segments_of_hand_made_links():
    links = {"time": 12.0, "why": "linksAt", "period": 0.5,
             "positions": {"uav1": (0.0, 0.0, 20.0), "uav2": (30.0, 40.0, 20.0), "uav3": (-5.0, 0.0, 20.0),
                           "uav4": (9.0, 9.0, 20.0)},
             "links": [("uav1", "uav2"), ("uav2", "uav1"), ("uav3", "uav1"), ("uav4", "uav1"), ("uav1", "uav4"),
                       ("uav2", "uav2")]}
    assert link_segments(links) == [("uav1", "uav2", True, (0.0, 0.0), (30.0, 40.0)),
                                    ("uav1", "uav3", False, (0.0, 0.0), (-5.0, 0.0)),
                                    ("uav1", "uav4", True, (0.0, 0.0), (9.0, 9.0))]
    assert link_segments(links, absent={"uav1"}) == []
    assert link_segments(None) == []


@pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                    reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")
def test_map_draws_the_pairs_in_range_at_the_moment_asked(tmp_path):
    # three UAVs fly out at 10 m/s: to 600 m north, to 600 m at 30 degrees east of north, and 600 m south; at
    # T = 40 s (legs start at about 16 s) each is about 240 m out: the two northern ones 2 * 240 * sin(15 deg) =
    # 124 m apart, both about 460 m from the southern one: one link, both ways, with a 300 m radio
    d = {"name": "links", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 3, "strategy": "C",
         "targets": [latlon(0, 600), latlon(300, 520), latlon(0, -600)], "step": 0.1, "stop_time": 45.0,
         "seed": 2, "comm": {"range": RANGE, "period": 0.5, "links_at": T}}
    path = tmp_path / "links.yaml"
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    ex = Execution(build_scenario(path, tmp_path / "links.ssp"), output=tmp_path / "run")
    ex.initialize()
    ex.simulate_until(45.0)
    ex.close("completed")
    uav_mon = next(m for m in ex.monitors if m.annotation_type == MONITOR_TYPE)
    comm = next(m for m in ex.monitors if m.annotation_type == COMM_TYPE)
    links = comm.links()
    assert links["why"] == "linksAt" and links["time"] == pytest.approx(T)
    pos = links["positions"]
    # the positions are where the UAVs were then (the recorded track, 1 s rows)
    traj = pd.read_csv(tmp_path / "run" / "trajectory.csv")
    for name, (x, y, _) in pos.items():
        row = traj[(traj.uav == name) & ((traj.time - T).abs() < 1e-6)].iloc[0]
        assert math.hypot(row.x - x, row.y - y) < 1e-9
    far = {(a, b) for a in pos for b in pos if a < b and math.dist(pos[a][:2], pos[b][:2]) > RANGE + 20.0}
    near = {(a, b) for a in pos for b in pos if a < b and math.dist(pos[a][:2], pos[b][:2]) < RANGE - 20.0}
    assert near == {("uav1", "uav2")} and len(far) == 2            # the geometry above, as flown
    uavs = uav_summaries(uav_mon, "completed")
    fig = map_figure(uav_mon, uavs, total_summary(uav_mon, uavs, "completed"))
    ax = fig.axes[0]
    drawn = [c for c in ax.collections if c.get_gid() == "comm_links"]
    assert len(drawn) == 1 and not [c for c in ax.collections if c.get_gid() == "comm_links_one_way"]
    segs = [[tuple(p) for p in s] for s in drawn[0].get_segments()]
    assert segs == [[tuple(pos["uav1"][:2]), tuple(pos["uav2"][:2])]]
    assert any("heard each other at t=40.0 s" in t.get_text() for t in ax.get_legend().get_texts())


def test_links_at_must_be_a_time(tmp_path):
    from master.errors import ScenarioError
    from uavstudy.scenario import load_scenario_yaml
    d = {"name": "bad", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 2, "strategy": "C",
         "targets": [latlon(0, 100), latlon(0, -100)], "comm": {"links_at": -3}}
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(d))
    with pytest.raises(ScenarioError) as ei:
        load_scenario_yaml(path)
    assert "bad.yaml: comm.links_at: must be >= 0" in str(ei.value) and "\n" not in str(ei.value)
    d["comm"] = {"links_at": 12.5}
    path.write_text(yaml.safe_dump(d))
    assert load_scenario_yaml(path).comm.links_at == 12.5
