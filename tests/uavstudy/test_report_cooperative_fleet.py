"""The fleet-level success of the C-against-B report (uavstudy/report/cooperative.py): a run's fleet mission is
complete when the fleet photographed every target (the run's total row: targets_visited = targets_total), whoever
did; the section gives C - B of it as a t interval over layouts, beside the per-UAV successes of B and C.

Hand-made campaign of five layouts, 2 UAVs, 10 targets: C hands a target to the better-placed UAV in every layout
(one per-UAV success fewer than B) while its fleet completes the mission in every layout, B's in one only."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from uavstudy.report import cooperative as co

LAYOUTS = [f"random-{i}" for i in range(1, 6)]
B_VISITED = [8, 9, 7, 10, 9]          # of 10: complete in layout 4 only
C_VISITED = [10, 10, 10, 10, 10]


def _tables():
    config = json.dumps({"comm.loss": 0.0, "comm.range": 300.0, "rules": "improved"}, sort_keys=True)
    rows, totals = [], []
    for i, lay in enumerate(LAYOUTS):
        for strategy, visited, successes in (("B", B_VISITED[i], 2), ("C", C_VISITED[i], 1)):
            run_id = f"{strategy}{i}"
            rows.append(dict(run_id=run_id, strategy=strategy, layout=lay, config=config, rules="improved", n_uavs=2,
                             area="zones", wind=0.0, successes=successes, uav_collided=0, zone_collided=0,
                             battery=50.0, distance_km=2.0, range=300.0 if strategy == "C" else np.nan,
                             loss=0.0 if strategy == "C" else np.nan))
            totals += [dict(run_id=run_id, uav="uav1", targets_visited=visited // 2, targets_total=np.nan,
                            energy_used_Wh_sum=np.nan),
                       dict(run_id=run_id, uav="total", targets_visited=visited, targets_total=10,
                            energy_used_Wh_sum=40.0)]
    return pd.DataFrame(rows), pd.DataFrame(totals)


def test_fleet_complete_is_every_target_visited_by_the_fleet():
    r, df = _tables()
    r = co.with_run_values(r, df)
    b = r[r.strategy == "B"].fleet_complete.tolist()
    c = r[r.strategy == "C"].fleet_complete.tolist()
    assert b == [0.0, 0.0, 0.0, 1.0, 0.0] and c == [1.0] * 5


def test_section_gives_fleet_completion_beside_per_uav_success(tmp_path):
    r, df = _tables()
    text = "\n".join(co.cooperative_md(r, df, tmp_path, "fleet"))
    # C - B per layout: 1, 1, 1, 0, 1: mean 0.8, sd 0.447, t(0.975, 4) = 2.776
    d = np.array([1, 1, 1, 0, 1], float)
    half = stats.t.ppf(0.975, 4) * d.std(ddof=1) / np.sqrt(5)
    row = next(x for x in text.split("\n") if x.startswith("| runs whose fleet photographed every target"))
    assert f"+0.800 [{0.8 - half:.3f}, {0.8 + half:.3f}]" in row and row.rstrip(" |").endswith("yes")
    # while the per-UAV success is one fewer in every layout: reversed (the interval is a point at -1)
    per_uav = next(x for x in text.split("\n") if x.startswith("| successful UAV missions per run | all |"))
    assert "-1.000" in per_uav and per_uav.rstrip(" |").endswith("reversed")
    levels = next(x for x in text.split("\n") if x.startswith("| all |") and "of 2.00" in x)
    assert [c.strip() for c in levels.strip("|").split("|")] == ["all", "2.00 of 2.00", "1.00 of 2.00", "0.200",
                                                                  "1.000", "5 / 5"]
