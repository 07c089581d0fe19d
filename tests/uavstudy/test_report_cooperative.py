"""The C-against-B section of the campaign report (uavstudy/report/cooperative.py) on a small hand-made B/C campaign
table: its intervals are the t intervals over per-layout means recomputed here with numpy/scipy, no "yes" where
an interval holds zero, and the level where the benefit disappears is the one worked out by hand below."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from uavstudy.report import cooperative as co
from uavstudy.report.findings import YES

LAYOUTS = ["random-1", "random-2", "random-3", "random-4"]
B_UAV = 2          # B loses two UAVs to a UAV-UAV collision in every layout
# C's UAV-UAV removals per (range, loss) and layout: C - B at 300 m and 50 m is about -2 (a clear benefit), at 15 m
# it scatters around 0
C_UAV = {(300.0, 0.0): [0, 0, 1, 0], (300.0, 0.5): [0, 1, 0, 0],
         (50.0, 0.0): [0, 0, 0, 1], (50.0, 0.5): [1, 0, 0, 0],
         (15.0, 0.0): [2, 1, 3, 2], (15.0, 0.5): [2, 2, 1, 3]}


def _config(rng, loss):
    return json.dumps({"comm.loss": loss, "comm.range": rng, "rules": "paper"}, sort_keys=True)


def _table():
    rows = []
    for i, lay in enumerate(LAYOUTS):
        # B flies once, with the channel values of one C setting (as cooperative.yaml's runs: do)
        rows.append(dict(run_id=f"b{i}", strategy="B", layout=lay, config=_config(300.0, 0.0), rules="paper",
                         n_uavs=4, area="zones", wind=0.0, uav_collided=B_UAV, zone_collided=1, successes=1,
                         battery=40.0, distance_km=3.0, targets_per_wh=0.10, fleet_complete=0.0, range=np.nan,
                         loss=np.nan))
        for (rg, ls), c in C_UAV.items():
            rows.append(dict(run_id=f"c{i}-{rg:g}-{ls:g}", strategy="C", layout=lay, config=_config(rg, ls),
                             rules="paper", n_uavs=4, area="zones", wind=0.0, uav_collided=c[i], zone_collided=1,
                             successes=1 + (B_UAV - c[i]) // 2, battery=40.0 - 2.0 * i, distance_km=3.0 + 0.1 * i,
                             targets_per_wh=0.10 + 0.01 * i, fleet_complete=float(c[i] == 0), range=rg, loss=ls))
    return pd.DataFrame(rows)


def _t_interval(per_layout):
    a = np.asarray(per_layout, float)
    m, se = a.mean(), a.std(ddof=1) / np.sqrt(a.size)
    h = stats.t.ppf(0.975, a.size - 1) * se
    return m, m - h, m + h


def _hand_per_layout(ranges=None, losses=None):
    """layout -> mean of C - B over the C runs of the chosen levels."""
    out = []
    for i in range(len(LAYOUTS)):
        d = [c[i] - B_UAV for (rg, ls), c in C_UAV.items()
             if (ranges is None or rg in ranges) and (losses is None or ls in losses)]
        out.append(np.mean(d))
    return out


def test_range_and_loss_intervals_are_t_intervals_over_per_layout_means():
    r = _table()
    by_range = co.effects_by(r, "uav_collided", "range")
    by_loss = co.effects_by(r, "uav_collided", "loss")
    overall = co.effects_by(r, "uav_collided")["all"]
    cases = [(by_range[rg], _hand_per_layout(ranges=[rg])) for rg in (15.0, 50.0, 300.0)]
    cases += [(by_loss[ls], _hand_per_layout(losses=[ls])) for ls in (0.0, 0.5)]
    cases += [(overall, _hand_per_layout())]
    for ci, per_layout in cases:
        m, lo, hi = _t_interval(per_layout)
        assert ci.n == len(LAYOUTS)
        assert ci.estimate == pytest.approx(m, abs=1e-12)
        assert ci.low == pytest.approx(lo, abs=1e-9) and ci.high == pytest.approx(hi, abs=1e-9)
    # the hand numbers: at 300 m the per-layout means are -1.75 on average, at 15 m exactly 0
    assert by_range[300.0].estimate == pytest.approx(-1.75)
    assert by_range[15.0].estimate == pytest.approx(0.0)


def test_no_yes_where_the_interval_holds_zero_and_where_the_benefit_disappears():
    r = _table()
    for axis in ("range", "loss"):
        for metric, _, sign in co.METRICS:
            for ci in co.effects_by(r, metric, axis).values():
                if ci.n >= 2 and np.isfinite(ci.low) and ci.low <= 0.0 <= ci.high:
                    assert co.verdict(ci, sign) != YES
    by_range = co.effects_by(r, "uav_collided", "range")
    # by hand: 300 m and 50 m exclude zero below it (yes), 15 m holds it -> the benefit disappears at 15 m
    hand = {rg: _t_interval(_hand_per_layout(ranges=[rg])) for rg in (300.0, 50.0, 15.0)}
    assert hand[300.0][2] < 0 and hand[50.0][2] < 0 and hand[15.0][1] <= 0 <= hand[15.0][2]
    assert co.disappears_at(by_range, -1, worse=-1) == 15.0
    # loss pools the three ranges: per-layout means at no loss -4/3, -5/3, -2/3, -1 (mean -7/6, sd 0.43:
    # [-1.85, -0.48]), at 50 % -1, -1, -5/3, -1 ([-1.70, -0.64]): shown at both levels, it does not disappear
    assert _hand_per_layout(losses=[0.0]) == pytest.approx([-4 / 3, -5 / 3, -2 / 3, -1.0])
    assert _hand_per_layout(losses=[0.5]) == pytest.approx([-1.0, -1.0, -5 / 3, -1.0])
    assert all(_t_interval(_hand_per_layout(losses=[ls]))[2] < 0 for ls in (0.0, 0.5))
    assert co.disappears_at(co.effects_by(r, "uav_collided", "loss"), -1, worse=+1) is None
    # and with C no better than B at 15 m in every layout, a range-only table stops at its best level
    only_15 = r[(r["strategy"] == "B") | (r["range"] == 15.0)]
    assert co.disappears_at(co.effects_by(only_15, "uav_collided", "range"), -1, worse=-1) == 15.0


def test_section_states_the_answers(tmp_path):
    lines = co.cooperative_md(_table(), None, tmp_path, "synthetic")
    text = "\n".join(lines)
    assert "## Strategy C against B" in text
    assert "at 15 m (not shown)" in text
    # the overall UAV-UAV row carries the interval recomputed here
    m, lo, hi = _t_interval(_hand_per_layout())
    row = next(x for x in text.split("\n") if x.startswith("| UAVs removed by UAV-UAV collisions per run | all |"))
    assert f"{m:+.3f} [{lo:.3f}, {hi:.3f}]" in row and row.rstrip(" |").endswith("yes")
    assert "not within the levels flown" in text
    assert (tmp_path / "fig_channel_benefit.png").is_file()
