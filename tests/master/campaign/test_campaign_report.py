"""The report from a known, hand-made campaign: intervals and tests checked against hand computation
and scipy; the statistics module against scipy on random data."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from master.campaign import blocked as bl
from master.campaign import stats as st
from master.campaign.report import build_report
from uavstudy.report import figure_data, table2, uav_frames
from master.campaign.table import build_table

scipy_stats = pytest.importorskip("scipy.stats")

STRATS, FLEETS, AREAS, WINDS = ("A", "B"), (1, 2), ("free", "zones"), (0.0, 0.1)


def _mission(strategy, n, area, wind, k):
    """Deterministic hand-made per-UAV results: A succeeds less, zones cause zone collisions, ..."""
    i = STRATS.index(strategy) * 100 + n * 10 + AREAS.index(area) * 4 + WINDS.index(wind) * 2 + k
    battery = 30.0 + 7.0 * STRATS.index(strategy) + 5.0 * n - 40.0 * wind + (i % 5)
    if area == "zones" and k == 0 and wind > 0:
        outcome = "zone_collision"
    elif strategy == "A" and n == 2 and area == "free" and wind == 0.0:
        outcome = "uav_collision"
    elif n == 1:
        # strategy A: 1 success of 4 single-UAV runs, strategy B: 3 of 4
        wins = {"A": {("free", 0.0)}, "B": {("free", 0.0), ("free", 0.1), ("zones", 0.0)}}[strategy]
        outcome = "success" if (area, wind) in wins else "battery_return"
    else:
        outcome = "success" if (i % 3) else "incomplete"
    return {"uav": f"uav{k + 1}", "index": k, "outcome": outcome, "success": outcome == "success",
            "remaining_battery_pct": battery, "distance_m": 1000.0 + 10 * i, "photos": 3 + i % 4,
            "removed_time": 20.0 + i if outcome.endswith("collision") else None}


def make_campaign(folder: Path):
    runs, rows = [], []
    for s in STRATS:
        for n in FLEETS:
            for a in AREAS:
                for w in WINDS:
                    rid = f"{s}{n}{a}{int(w * 100):02d}"
                    params = {"strategy": s, "n_uavs": n, "variant": a, "wind.probability": w}
                    uavs = [_mission(s, n, a, w, k) for k in range(n)]
                    total = {"strategy": s, "uavs": n, "scenario": f"paper_{a}", "wind_probability": w,
                             "run_outcome": "completed", "uavs_successful": sum(u["success"] for u in uavs),
                             "success": all(u["success"] for u in uavs),
                             "distance_m_sum": sum(u["distance_m"] for u in uavs),
                             "photos_sum": sum(u["photos"] for u in uavs),
                             "uav_collisions": sum(u["outcome"] == "uav_collision" for u in uavs) // 2,
                             "zone_collisions": sum(u["outcome"] == "zone_collision" for u in uavs)}
                    rec = {"run_id": rid, "params": params, "rep": 0, "seed": 1, "outcome": "completed",
                           "error": None, "wall_time_s": 1.0, "inputs_sha256": "x", "scenario_sha256": "y",
                           "summary": {"total": total, "uavs": uavs}}
                    runs.append({"run_id": rid, "params": params, "rep": 0, "seed": 1, "inputs_sha256": "x"})
                    rows.append(rec)
    # one failed run (no summary): listed, never analysed
    runs.append({"run_id": "broken", "params": {"strategy": "A", "n_uavs": 1, "variant": "free",
                                                "wind.probability": 0.05}, "rep": 0, "seed": 1,
                 "inputs_sha256": "x"})
    rows.append({"run_id": "broken", "params": runs[-1]["params"], "rep": 0, "seed": 1, "outcome": "failed",
                 "error": "worker process died with signal 11 (SIGSEGV)", "wall_time_s": 0.5, "inputs_sha256": "x"})
    (folder / "runs").mkdir(parents=True)
    for rec in rows:
        (folder / "runs" / f"{rec['run_id']}.json").write_text(json.dumps(rec))
    manifest = {"format": 1, "name": "hand", "description": "hand-made", "seed": 1, "repetitions": 1,
                "kind": "uav", "param_keys": ["strategy", "n_uavs", "variant", "wind.probability"], "keep": "summary",
                "options": {}, "runs": runs}
    (folder / "campaign.json").write_text(json.dumps(manifest))
    return rows


@pytest.fixture
def hand(tmp_path):
    rows = make_campaign(tmp_path)
    df = build_table(tmp_path)
    u, r = uav_frames(df)
    return tmp_path, rows, df, u, r


def test_table_has_a_row_per_uav_and_a_total_per_run(hand):
    _, rows, df, u, r = hand
    assert len(df) == 16 * 1 + 8 * 1 + 8 * 2 + 1        # totals + 1-UAV rows + 2-UAV rows + the failed run
    assert list(df.columns[:5]) == ["run_id", "strategy", "n_uavs", "variant", "wind.probability"]
    assert len(u) == 24 and len(r) == 16                  # the failed run is not analysed


def test_success_counts_and_layout_level_statistics_by_hand(hand):
    """One repetition of a fixed area: one replicate, so every statistic has its estimate and no interval (a
    t interval needs two layouts), and no verdict can be "yes"; totals are shown per three layouts (the
    paper's grid)."""
    _, _, _, u, r = hand
    fd = figure_data(u, r)
    k, m, ci = fd["fig5"][("A", 1)]
    assert (k, m) == (1, 4) and ci.estimate == 3.0 and ci.n == 1 and math.isnan(ci.low)
    assert fd["fig5"][("B", 1)][:2] == (3, 4)
    t2 = {x["key"]: x for x in table2(u, r)}
    # B - A successes per run, mean over the 8 (n, area, wind) cells of the one layout, by hand from _mission
    diffs = [sum(_mission("B", n, a, w, k)["success"] - _mission("A", n, a, w, k)["success"] for k in range(n))
             for n in FLEETS for a in AREAS for w in WINDS]
    e = t2["success"]["effect"]
    assert e.n == 1 and e.estimate == pytest.approx(np.mean(diffs)) and math.isnan(e.p)
    assert t2["success"]["better"] == "not shown"


def test_means_totals_and_paired_differences_against_hand_computation(hand):
    _, _, _, u, r = hand
    fd = figure_data(u, r)
    # mean over UAV missions of strategy A in the free area (weights: UAVs per run)
    vals = np.array([_mission("A", n, "free", w, k)["remaining_battery_pct"]
                     for n in FLEETS for w in WINDS for k in range(n)])
    ci = fd["fig6"][("A", "free")]
    assert ci.n == 1 and ci.estimate == pytest.approx(vals.mean())
    d = np.array([sum(_mission("B", n, a, 0.1, k)["distance_m"] for k in range(n)) / 1000
                  for n in FLEETS for a in AREAS])
    assert fd["fig8"][("B", 0.1)].estimate == pytest.approx(3 * d.sum())        # per three layouts
    # collisions per impact point and area: removed UAVs, per three layouts
    assert fd["fig9"][("A", "free", "uav")].estimate == 6 and fd["fig9"][("B", "free", "uav")].estimate == 0
    assert fd["fig9"][("A", "zones", "zone")].estimate == 6 and fd["fig9"][("B", "zones", "zone")].estimate == 6
    t2 = {x["key"]: x for x in table2(u, r)}
    dist = [sum(_mission("B", n, a, w, k)["distance_m"] - _mission("A", n, a, w, k)["distance_m"]
                for k in range(n)) / 1000 for n in FLEETS for a in AREAS for w in WINDS]
    assert t2["distance"]["effect"].estimate == pytest.approx(np.mean(dist))
    # B keeps 7 points more battery in every UAV of every cell: 7, but one layout shows nothing
    e = t2["energy"]["effect"]
    assert e.estimate == pytest.approx(7.0) and t2["energy"]["better"] == "not shown"


def test_build_report_of_a_one_layout_campaign_says_it_is_too_small(hand):
    folder, *_ = hand
    path = build_report(folder)
    assert path == folder / "report" / "report.md"
    text = path.read_text()
    for k in ("fig5_success_per_fleet_size", "fig6_battery_per_area", "fig7_battery_per_wind",
              "fig8_distance_per_wind", "fig9_collisions_per_impact", "fig10_battery_per_fleet_size"):
        assert (folder / "report" / f"{k}.png").stat().st_size > 5000
        assert f"({k}.png)" in text
    # scored against nothing: a too-small campaign says so instead of a column of "no"
    assert "## Too small to score against the paper" in text and "1 independent replicate (" in text
    assert "## Our numbers next to the paper's" not in text and "Table II" not in text
    assert "n = 16 runs, 24 UAV missions, 8 configurations" in text
    captions = [line for line in text.splitlines() if line.startswith("*Fig. ")]
    assert len(captions) == 6 and all("n = 16 runs, 24 UAV missions" in c for c in captions)
    assert "worker process died with signal 11 (SIGSEGV)" in text
    assert "wind probability 10.0 %" in text and "restricted" in text
    # 16 runs of 1.0 s and the failed one of 0.5 s: 16.5 s, not "0.3 min"
    assert "sum 16.5 s." in text


def test_intervals_stop_where_the_quantity_does():
    """Hand-computed: [10, 90] has mean 50, s = 56.569, t(0.975, 1) = 12.706, half-width 508.2: the battery
    interval [-458.2, 558.2] is cut to [0, 100]."""
    ci = st.mean_ci([10.0, 90.0], floor=0.0, ceiling=100.0)
    assert (ci.estimate, ci.low, ci.high) == (50.0, 0.0, 100.0)
    plain = st.mean_ci([10.0, 90.0])
    assert plain.low == pytest.approx(50 - 12.706205 * 56.568542 / math.sqrt(2), abs=1e-4)
    # [0, 1, 2] per run: mean 1, s = 1, t(0.975, 2) = 4.302653, half-width 2.484138 -> total 3 [0, 10.45],
    # cut at 4 UAVs that flew
    tot = st.total_ci([0, 1, 2], floor=0.0, ceiling=4.0)
    assert (tot.estimate, tot.low, tot.high) == (3.0, 0.0, 4.0)
    assert st.total_ci([0, 1, 2], floor=0.0).high == pytest.approx(3 * (1 + 4.302653 / math.sqrt(3)), abs=1e-5)
    assert st.mean_ci([5.0, 7.0], floor=0.0, ceiling=100.0).low == 0.0     # 6 - 12.7: cut at 0 as well


def test_ratio_and_duration_texts():
    from master.campaign.report import fmt_duration
    from uavstudy.report import ratio_text
    assert ratio_text(6, 2) == "3.00×" and ratio_text(0, 0) == "both 0"
    assert ratio_text(2, 0) == "n/a: none in the denominator"
    assert fmt_duration(16.5) == "16.5 s" and fmt_duration(90.0) == "1.5 min" and fmt_duration(7200.0) == "2.00 h"


def test_stats_module_agrees_with_scipy():
    rng = np.random.default_rng(1)
    for df in (1, 2, 5, 30, 300):
        assert st.t_ppf(0.975, df) == pytest.approx(scipy_stats.t.ppf(0.975, df), rel=1e-10)
    for _ in range(60):
        n1, n2 = rng.integers(1, 14, 2)
        x = rng.integers(0, 6, n1).astype(float) if rng.random() < 0.5 else rng.normal(size=n1)
        y = rng.integers(0, 6, n2).astype(float) if rng.random() < 0.5 else rng.normal(0.7, size=n2)
        u, p = st.mann_whitney_u(x, y)
        ref = scipy_stats.mannwhitneyu(x, y, alternative="two-sided")
        assert u == pytest.approx(ref.statistic) and p == pytest.approx(ref.pvalue, rel=1e-9, abs=1e-12)
        a, b, c, d = (int(v) for v in rng.integers(0, 25, 4))
        assert st.fisher_exact(a, b, c, d) == pytest.approx(scipy_stats.fisher_exact([[a, b], [c, d]]).pvalue,
                                                            rel=1e-9, abs=1e-12)
    ci = st.wilson_ci(7, 20)
    ref = scipy_stats.binomtest(7, 20).proportion_ci(method="wilson")
    assert (ci.low, ci.high) == (pytest.approx(ref.low), pytest.approx(ref.high))
    # exact Mann-Whitney by hand: [1, 2, 3] vs [4, 5, 6] -> U = 0, P(U <= 0) = 1/20, two-sided 0.1
    assert st.mann_whitney_u([1, 2, 3], [4, 5, 6]) == (0.0, pytest.approx(0.1))
    m = st.mean_ci([40, 50, 60])
    assert m.estimate == 50 and m.low == pytest.approx(50 - 4.302652729749464 * 10 / math.sqrt(3))


def test_paired_tests_agree_with_scipy_and_hand_computation():
    rng = np.random.default_rng(7)
    for _ in range(80):
        n = int(rng.integers(1, 70))
        d = rng.integers(-4, 5, n).astype(float) if rng.random() < 0.5 else rng.normal(0.3, size=n)
        t, p, method = st.wilcoxon_signed_rank(d)
        nz = d[d != 0]
        if nz.size == 0:
            assert math.isnan(p)
            continue
        ref = scipy_stats.wilcoxon(nz, zero_method="wilcox", correction=False, method=method)
        # scipy's two-sided statistic is min(T+, T-); ours is T+
        assert min(t, nz.size * (nz.size + 1) / 2 - t) == pytest.approx(ref.statistic)
        assert p == pytest.approx(ref.pvalue, rel=1e-9, abs=1e-12)
        b, c = (int(v) for v in rng.integers(0, 30, 2))
        assert st.mcnemar_exact(b, c) == pytest.approx(scipy_stats.binomtest(min(b, c), b + c, 0.5).pvalue
                                                       if b + c else 1.0, rel=1e-12)
    # by hand: d = (1, 2, 3) all positive -> T+ = 6, P(T+ >= 6) = 1/8, two-sided 0.25
    assert st.wilcoxon_signed_rank([1.0, 2.0, 3.0]) == (6.0, pytest.approx(0.25), "exact")
    # McNemar: 0 vs 5 discordant pairs -> 2 * (1/2)^5 = 0.0625
    assert st.mcnemar_exact(0, 5) == pytest.approx(0.0625)


