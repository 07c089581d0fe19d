"""map.png of a large fleet: a legend by outcome (with its number of UAVs) instead of one entry per UAV, the UAVs that
never left their pads as a ring of pad dots rather than a pile of landing markers at the base, and a title whose
counts say what they count (collision events vs UAVs lost)."""
import math
from types import SimpleNamespace

import numpy as np
import pandas as pd

from uavstudy.build import pad_positions
from uavstudy.outputs import END_MARKERS, MAX_UAV_LEGEND, OUTCOME_COLOURS, map_figure, map_title

LANDED_SIZE = END_MARKERS["landed"][0]["s"]


def fleet(outcomes: list[str]):
    """A finished fleet as the map reads it: UAV k flies from its pad 300 m out and back (no_targets: stays), a
    collided one ends where it was removed, 300 m out."""
    n = len(outcomes)
    pads = pad_positions(n)
    t = np.arange(0.0, 61.0, 1.0)
    rows, records, uavs = [], [], []
    for k, (out, (hx, hy)) in enumerate(zip(outcomes, pads)):
        a = 2 * math.pi * k / n
        r = np.zeros_like(t) if out == "no_targets" else 300.0 * np.sin(np.pi * t / 60.0)
        removed = out == "uav_collision"
        if removed:
            r = np.where(t <= 30.0, r, np.nan)
        x, y = hx + r * math.sin(a), hy + r * math.cos(a)
        keep = ~np.isnan(x)
        rows.append(pd.DataFrame({"time": t[keep], "uav": f"uav{k + 1}", "x": x[keep], "y": y[keep]}))
        records.append(SimpleNamespace(removed_time=30.0 if removed else None, removed_reason=out if removed else None,
                                       removed_pos=(x[30], y[30], 20.0) if removed else None, took_off=True))
        uavs.append({"uav": f"uav{k + 1}", "outcome": out, "visited_targets": [], "final_phase": 4,
                     "final_x": hx, "final_y": hy})
    cfg = SimpleNamespace(scenario="fleet", strategy="B", zones=[], targets=np.zeros((0, 2)), origin=(-7.0, -35.0, 500.0),
                          uavs=[SimpleNamespace(name=f"uav{k + 1}", home=p) for k, p in enumerate(pads)])
    counts = {o: outcomes.count(o) for o in set(outcomes)}
    total = {"uavs": n, "mission_end_time": 60.0, "end_time": 60.0, "run_outcome": "completed",
             "uavs_successful": counts.get("success", 0), "targets_visited": 0, "targets_total": 0,
             "uav_collisions": counts.get("uav_collision", 0) // 2, "zone_collisions": 0, "outcomes": counts}
    mon = SimpleNamespace(cfg=cfg, records=records, track_p=[], track_t=[])
    return mon, uavs, total, pd.concat(rows, ignore_index=True)


def legend_and_markers(mon, uavs, total, traj):
    fig = map_figure(mon, uavs, total, traj)
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    markers = [c for c in ax.collections if hasattr(c, "get_sizes") and c.get_offsets().shape[0] == 1]
    return labels, markers


def test_title_counts_collision_events_and_the_uavs_they_cost():
    mon, uavs, total, _ = fleet(["success"] * 4)
    total = dict(total, uav_collisions=5, zone_collisions=2, outcomes={"uav_collision": 10, "zone_collision": 2})
    title = map_title(mon.cfg, total)
    assert "5 UAV-UAV collisions (10 UAVs lost), 2 zone incursions" in title
    total = dict(total, uav_collisions=1, zone_collisions=0, outcomes={"uav_collision": 2})
    assert "1 UAV-UAV collision (2 UAVs lost), 0 zone incursions" in map_title(mon.cfg, total)


def test_a_large_fleet_has_a_legend_by_outcome_and_no_blob_at_the_base():
    outcomes = ["success"] * 14 + ["uav_collision"] * 10 + ["no_targets"] * 40      # the 64-UAV run of issue 30
    mon, uavs, total, traj = fleet(outcomes)
    assert len(uavs) > MAX_UAV_LEGEND
    labels, markers = legend_and_markers(mon, uavs, total, traj)
    assert "no_targets: 40 UAVs" in labels and "success: 14 UAVs" in labels and "uav_collision: 10 UAVs" in labels
    assert not any(lb.startswith("uav") and ":" in lb and lb.split(":")[0][3:].isdigit() for lb in labels)
    assert "landed at base" not in labels                  # no pile of 54 landing markers at the base ...
    assert not [m for m in markers if m.get_sizes()[0] == LANDED_SIZE]
    pads = [m for m in markers if m.get_sizes()[0] < 10]  # ... but one small dot per pad, in its outcome's colour
    assert len(pads) == 64
    from matplotlib.colors import to_rgba
    by_colour = {}
    for m in pads:
        by_colour[tuple(m.get_facecolors()[0])] = by_colour.get(tuple(m.get_facecolors()[0]), 0) + 1
    assert by_colour == {to_rgba(OUTCOME_COLOURS[o]): outcomes.count(o) for o in set(outcomes)}


def test_a_small_fleet_keeps_its_legend_per_uav():
    mon, uavs, total, traj = fleet(["success", "success", "uav_collision", "uav_collision"])
    labels, markers = legend_and_markers(mon, uavs, total, traj)
    assert len([m for m in markers if m.get_sizes()[0] == LANDED_SIZE]) == 2
    assert [lb for lb in labels if lb.startswith("uav")] == \
        ["uav1: success", "uav2: success", "uav3: uav_collision", "uav4: uav_collision"]
    assert "landed at base" in labels and "UAV-UAV collision" in labels
