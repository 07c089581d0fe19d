"""Blocked (paired) statistics and agreement by value, against hand computation."""
import math

import numpy as np
import pandas as pd
import pytest

from master.campaign import blocked as bl
from master.campaign import stats as st

T975_2 = 4.302652729749464      # t(0.975, 2 df), tables
T975_3 = 3.182446305284263      # t(0.975, 3 df)


def three_layouts():
    """3 layouts x 2 strategies, two UAVs per run; B beats A by 1, 2 and 3 points of mean battery."""
    rows = []
    for layout, base, gain in (("L1", 40.0, 1.0), ("L2", 55.0, 2.0), ("L3", 30.0, 3.0)):
        for s, extra in (("A", 0.0), ("B", gain)):
            # the two UAVs of a run differ (+-5) but their mean is base + extra
            rows += [{"layout": layout, "strategy": s, "uav": "uav1", "battery": base + extra - 5.0},
                     {"layout": layout, "strategy": s, "uav": "uav2", "battery": base + extra + 5.0}]
    return pd.DataFrame(rows)


def test_paired_difference_over_three_layouts_by_hand():
    d = bl.paired_differences(three_layouts(), "battery", "strategy", "A", "B", ["layout"])
    assert list(d["layout"]) == ["L1", "L2", "L3"] and list(d["diff"]) == [1.0, 2.0, 3.0]
    e = bl.blocked_effect(d["diff"])
    # mean 2, sd 1, n 3: 2 +- t(0.975, 2) * 1 / sqrt(3)
    assert e.estimate == 2.0 and e.n_blocks == 3 and e.sd == 1.0 and e.d_z == 2.0
    assert e.low == pytest.approx(2 - T975_2 / math.sqrt(3), abs=1e-9)
    assert e.high == pytest.approx(2 + T975_2 / math.sqrt(3), abs=1e-9)
    # sign flips of (1, 2, 3): 8 equally likely sums, |sum| >= 6 only for +++ and ---: p = 2/8
    assert e.p == 0.25 and not e.significant
    # the bootstrap resamples the three blocks: its interval lies within [1, 3] (means of resamples)
    assert 1.0 <= e.boot_low <= e.boot_high <= 3.0


def test_stratified_interval_does_not_pool_unlike_configurations():
    """Two configurations X (differences 1, 3) and Y (10, 12): mean 6.5.  Within-stratum variances 2 and 2,
    weights 1/2: var = 2 * (1/4 * 2 / 2) = 0.5, Satterthwaite df = 0.5^2 / (2 * 0.25^2 / 1) = 2, half-width
    t(0.975, 2) sqrt(0.5).  Pooled into one sample the sd is sqrt(85/3) = 5.323 and the half-width t(0.975, 3) 5.323 / 2."""
    d = [1.0, 3.0, 10.0, 12.0]
    e = bl.blocked_effect(d, strata=["X", "X", "Y", "Y"])
    assert e.estimate == 6.5 and e.n_strata == 2
    assert (e.low, e.high) == (pytest.approx(6.5 - T975_2 * math.sqrt(0.5)), pytest.approx(6.5 + T975_2 * math.sqrt(0.5)))
    pooled = bl.blocked_effect(d)
    sd = float(np.std(d, ddof=1))
    assert sd == pytest.approx(math.sqrt(85 / 3))
    assert pooled.high == pytest.approx(6.5 + T975_3 * sd / 2)
    assert pooled.high - pooled.low > 2.5 * (e.high - e.low)
    # levels: the same formula, cut to what the quantity can take
    ci = bl.stratified_mean_ci([1.0, 3.0, 10.0, 12.0], ["X", "X", "Y", "Y"], floor=6.0)
    assert ci.estimate == 6.5 and ci.low == 6.0 and ci.high == pytest.approx(6.5 + T975_2 * math.sqrt(0.5))


def test_sign_flip_test_exact_and_monte_carlo():
    assert bl.sign_flip_p([1.0, -1.0]) == 1.0
    assert bl.sign_flip_p([2.0, 2.0, 2.0, 2.0, 2.0]) == pytest.approx(2 / 32)
    # 20 equal positive differences: exact p = 2 / 2^20; the Monte Carlo version's floor is 1 / 20001
    assert bl.sign_flip_p([1.0] * 20) == pytest.approx(1 / (bl.PERMUTATIONS + 1))
    assert math.isnan(bl.sign_flip_p([]))


def test_blocks_missing_a_level_are_left_out_and_sums_aggregate():
    df = pd.DataFrame({"block": ["a", "a", "a", "b"], "s": ["A", "B", "B", "A"], "x": [1.0, 2.0, 5.0, 9.0]})
    d = bl.paired_differences(df, "x", "s", "A", "B", ["block"], agg="sum")
    assert list(d["block"]) == ["a"] and list(d["diff"]) == [6.0]


def test_agreement_is_by_value_with_a_stated_tolerance():
    ours = st.CI(41.0, 40.0, 42.0, 100)
    assert bl.agrees_by_value(41.83, ours, 0.0).agrees is True        # inside our interval
    assert bl.agrees_by_value(43.5, ours, 1.0).agrees is False        # 1.5 above, tolerance 1
    assert bl.agrees_by_value(43.5, ours, 2.0).agrees is True
    a = bl.agrees_by_value(270.0, 255.0, 10.0)                         # no interval: the value itself
    assert a.agrees is False and "-15" in a.text and "±10" in a.text
    assert bl.agrees_by_value(0.0, 0.0, 0.0).agrees is True
    assert bl.agrees_by_value(1.0, st.CI(math.nan, math.nan, math.nan, 0), 1.0).agrees is None


def _runs(config_value, single_uav_successes, b_minus_a_km):
    """Runs of one configuration (factor f): A/B x 1-2 UAVs x wind 0/0.15 x 4 layouts; B flies ``b_minus_a_km``
    km more than A in every pair (plus a layout-dependent wobble that B and A share), a single UAV of strategy B
    succeeds ``single_uav_successes`` times per run."""
    from master.campaign.identity import canonical_json
    rows = []
    for s in ("A", "B"):
        for n in (1, 2):
            for w in (0.0, 0.15):
                for rep in range(4):
                    cfg = canonical_json({"f": config_value})
                    cell = f"{cfg}|{n}|free|{w:g}"
                    rows.append({"run_id": f"{config_value}{s}{n}{w}{rep}", "strategy": s, "n_uavs": n,
                                 "area": "free", "wind": w, "rep": rep, "layout": f"random-{rep}", "config": cfg,
                                 "cell": cell, "block": f"{cell}|{rep}",
                                 "successes": single_uav_successes if (n == 1 and s == "B") else (1 if s == "B" else 0),
                                 "battery": 40.0 - 10 * w - rep,
                                 "distance_km": 5.0 + rep + (b_minus_a_km + 0.1 * rep if s == "B" else 0),
                                 "photos": 10, "collisions": 0, "collision_events": 0, "uav_collided": 0,
                                 "zone_collided": 0, "uav_events": 0})
    return rows


def test_sensitivity_names_the_configuration_that_moves_or_flips_a_finding():
    from uavstudy.report import REVERSED, YES, sensitivity_findings
    r = pd.DataFrame(_runs(1, 0, -0.5) + _runs(2, 1, +0.5))
    u = r[["run_id"]]
    design = {"baseline": {"f": 1}, "one_at_a_time": {"f": [2]}, "factorial": {}}
    sf = sensitivity_findings(u, r, design)
    base, other = '{"f":1}', '{"f":2}'
    assert sf["baseline"] == base and sf["labels"][other] == "f = 2"
    assert sf["roles"][other] == ["one_at_a_time:f"]
    # B - A distance per layout: -0.5 + 0.1 rep at the baseline (-0.5, -0.4, -0.3, -0.2: B shorter, yes) and
    # +0.5 + 0.1 rep at f = 2 (reversed); the change is +1.0 in every layout: an interval [1, 1] excluding 0
    key = ("distance_total", "B - A per run", "direction")
    assert sf["statements"][base][key].verdict == YES
    (move,) = sf["moves"][key]
    assert move["config"] == other and move["verdict"] == REVERSED and move["flipped"] and move["moved"]
    assert move["delta"].estimate == pytest.approx(1.0) and move["delta"].n == 4
    # no single UAV succeeds at f = 1 (0 per three layouts: within the paper's 0); at f = 2 each single-UAV B
    # run succeeds in every layout: 2 runs per layout x 3 = 6 per three layouts, outside
    key = ("success_1", "B per 3 layouts", "magnitude")
    assert sf["statements"][base][key].verdict == "within"
    (move,) = sf["moves"][key]
    assert move["verdict"] == "outside" and move["stat"].estimate == pytest.approx(6.0)
    # the battery is the same in both configurations: nothing moves B - A battery
    assert sf["moves"][("battery_total", "B - A (mission means)", "direction")] == []
