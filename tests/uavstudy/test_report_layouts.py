"""The report's statistics at the level of the layout, recomputed independently from results.parquet, and the
consistency of its verdicts with its intervals.

A small synthetic campaign is written to disk (run records and campaign.json, as the runner writes them): 6
random layouts x strategies A/B x 1-2 UAVs x free/restricted area x wind 0/15 %, with a layout effect shared by
every run of a layout (so runs are not independent, layouts are) and per-run noise, all from a seeded
generator.  The expected intervals are computed here with numpy and scipy from the parquet table, never with
the report's functions.
"""
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from master.campaign.report import build_report
from master.campaign.table import build_table, write_table
from uavstudy.report import NOT_SHOWN, REVERSED, YES, finding_rows, paper_comparison, table2, uav_frames
from uavstudy.report import markdown
from uavstudy.report.markdown import CAPTIONS

scipy_stats = pytest.importorskip("scipy.stats")

LAYOUTS, STRATS, FLEETS, AREAS, WINDS = 6, ("A", "B"), (1, 2), ("free", "zones"), (0.0, 0.15)


def _campaign(folder: Path, seed: int = 7, layouts: int = LAYOUTS) -> None:
    rng = np.random.default_rng(seed)
    runs, records = [], []
    for rep in range(layouts):
        lay_battery = rng.normal(0.0, 8.0)             # the layout moves every run of it
        lay_gain = rng.normal(0.6, 0.5)                # B's advantage differs by layout
        for s in STRATS:
            for n in FLEETS:
                for a in AREAS:
                    for w in WINDS:
                        rid = f"{s}{n}{a}{int(w * 100):02d}r{rep}"
                        params = {"strategy": s, "n_uavs": n, "variant": a, "wind.probability": w}
                        uavs = []
                        for k in range(n):
                            zone_hit = a == "zones" and rng.random() < (0.5 if s == "A" else 0.3)
                            succ = (not zone_hit) and rng.random() < (0.3 + (lay_gain * 0.3 if s == "B" else 0))
                            battery = float(np.clip(40 + lay_battery + 5 * n - 30 * w + (25 if zone_hit else 0)
                                                    + (3 if s == "B" else 0) + rng.normal(0, 4), 0, 100))
                            outcome = "zone_collision" if zone_hit else ("success" if succ else "battery_return")
                            uavs.append({"uav": f"uav{k + 1}", "index": k, "outcome": outcome, "success": succ,
                                         "remaining_battery_pct": battery,
                                         "distance_m": float(2000 + 300 * rng.normal() - (900 if zone_hit else 0)),
                                         "photos": int(rng.integers(3, 12)),
                                         "removed_time": float(rng.uniform(20, 300)) if zone_hit else None})
                        total = {"strategy": s, "uavs": n, "scenario": f"paper_{a}", "wind_probability": w,
                                 "run_outcome": "completed", "uavs_successful": sum(u["success"] for u in uavs),
                                 "success": all(u["success"] for u in uavs),
                                 "distance_m_sum": sum(u["distance_m"] for u in uavs),
                                 "photos_sum": sum(u["photos"] for u in uavs), "uav_collisions": 0,
                                 "zone_collisions": sum(u["outcome"] == "zone_collision" for u in uavs),
                                 "settings": {"layout_id": f"random-{1000 + rep}"}}
                        seed_run = 1 + rep * 100 + FLEETS.index(n) * 10 + AREAS.index(a) * 2 + WINDS.index(w)
                        records.append({"run_id": rid, "params": params, "rep": rep, "seed": seed_run,
                                        "outcome": "completed", "error": None, "wall_time_s": 0.1,
                                        "inputs_sha256": "x", "scenario_sha256": "y",
                                        "summary": {"total": total, "uavs": uavs}})
                        runs.append({"run_id": rid, "params": params, "rep": rep, "seed": seed_run,
                                     "inputs_sha256": "x"})
    (folder / "runs").mkdir(parents=True)
    for rec in records:
        (folder / "runs" / f"{rec['run_id']}.json").write_text(json.dumps(rec))
    manifest = {"format": 1, "name": "layouts", "description": "synthetic, layouts as replicates", "seed": seed,
                "repetitions": layouts, "kind": "uav",
                "param_keys": ["strategy", "n_uavs", "variant", "wind.probability"], "keep": "summary",
                "options": {}, "runs": runs}
    (folder / "campaign.json").write_text(json.dumps(manifest))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("layouts")
    _campaign(folder)
    write_table(folder)
    u, r = uav_frames(build_table(folder))
    text = build_report(folder).read_text(encoding="utf-8")
    return folder, u, r, text, {f.key: f for f in finding_rows(u, r)}


def _t_interval(values):
    """Independent reference: mean, 95 % t interval and one-sample t-test p over the per-layout values."""
    v = np.asarray(values, dtype=float)
    ci = scipy_stats.t.interval(0.95, v.size - 1, loc=v.mean(), scale=scipy_stats.sem(v))
    return v.mean(), ci[0], ci[1], scipy_stats.ttest_1samp(v, 0.0).pvalue


def _totals(folder):
    """One row per run from results.parquet: the run's total row, with its UAV rows' outcomes counted."""
    t = pd.read_parquet(folder / "results.parquet")
    uav = t[t["uav"].notna() & (t["uav"] != "total")]
    tot = t[t["uav"] == "total"].set_index("run_id")
    per_run = uav.groupby("run_id").agg(successes=("success", "sum"), battery=("remaining_battery_pct", "mean"))
    tot = tot.join(per_run)
    tot["layout"] = tot["settings.layout_id"]
    return tot.reset_index()


def test_three_intervals_recomputed_at_the_layout_level_from_the_parquet_table(campaign):
    folder, u, r, text, found = campaign
    runs = _totals(folder)
    assert runs["layout"].nunique() == LAYOUTS
    # 1. B - A successes per run: in each layout the mean over its 8 cells of B - A, then t over 6 layouts
    wide = runs.pivot_table(index=["layout", "n_uavs", "variant", "wind.probability"], columns="strategy",
                            values="successes")
    per_layout = (wide["B"] - wide["A"]).groupby(level="layout").mean()
    m, lo, hi, p = _t_interval(per_layout.to_numpy())
    got = found["success_dir"].parts[0].stat
    assert got.n == LAYOUTS
    assert (got.estimate, got.low, got.high, got.p) == (pytest.approx(m), pytest.approx(lo), pytest.approx(hi),
                                                        pytest.approx(p, rel=1e-6))
    # 2. restricted - free battery (mean of the run's UAVs): paired on strategy, fleet and wind in each layout
    wide = runs.pivot_table(index=["layout", "strategy", "n_uavs", "wind.probability"], columns="variant",
                            values="battery")
    m, lo, hi, p = _t_interval((wide["zones"] - wide["free"]).groupby(level="layout").mean().to_numpy())
    got = found["battery_zones"].parts[0].stat
    assert (got.estimate, got.low, got.high, got.p) == (pytest.approx(m), pytest.approx(lo), pytest.approx(hi),
                                                        pytest.approx(p, rel=1e-6))
    # 3. strategy A's total distance per the paper's 420 missions: per layout km / missions, x 420
    a = runs[runs["strategy"] == "A"]
    per_layout = a.groupby("layout").apply(lambda g: g["distance_m_sum"].sum() / 1000 / g["n_uavs"].sum(),
                                           include_groups=False) * 420
    v = per_layout.to_numpy()
    lo, hi = scipy_stats.t.interval(0.95, v.size - 1, loc=v.mean(), scale=scipy_stats.sem(v))
    got = found["distance_total"].magnitudes[0].stat
    assert (got.estimate, got.low, got.high) == (pytest.approx(v.mean()), pytest.approx(lo), pytest.approx(hi))
    # and the report prints those numbers
    s = found["success_dir"].parts[0].stat
    assert f"[{s.low:.2f}, {s.high:.2f}]" in text


def _layout_stats(comparison, t2):
    for c in comparison:
        for p in c["finding"].parts:
            yield c["key"], p.label, p.stat, p.verdict
    for x in t2:
        yield "table2", x["metric"], x["effect"], x["part"].verdict


def test_no_verdict_says_yes_beside_an_interval_that_includes_the_null(campaign):
    folder, u, r, text, _ = campaign
    seen = set()
    for key, label, s, verdict in _layout_stats(paper_comparison(u, r), table2(u, r)):
        includes_null = not (s.low <= (s.null or 0.0) <= s.high) is False if math.isfinite(s.low) else True
        if verdict in (YES, REVERSED):
            assert not includes_null, (key, label, s)
        if math.isfinite(s.p):
            # one method: p < 0.05 exactly when the interval excludes the null
            assert (s.p < 0.05) == (not includes_null), (key, label, s)
        if includes_null:
            assert verdict == NOT_SHOWN, (key, label, s)
        seen.add(verdict)
    assert seen >= {YES, NOT_SHOWN}              # the check saw both kinds of verdict
    # the same over the printed report: no "p < 0.05" beside an interval that includes 0 (signed statistics)
    hits = re.findall(r"([+-]\d+\.\d+)[^\[\]|;]*?\[(-?\d+\.\d+), (-?\d+\.\d+)\], p (< 0\.0001|= [0-9.]+)", text)
    assert len(hits) > 10
    for est, lo, hi, p in hits:
        significant = p.startswith("<") or float(p[2:]) < 0.05
        assert significant == (not (float(lo) <= 0.0 <= float(hi))), (est, lo, hi, p)


def test_a_campaign_with_one_layout_says_it_is_too_small(tmp_path, monkeypatch):
    """Only the text is asserted: the figures are not drawn (drawing a one-layout campaign's figures is checked by
    tests/master/campaign/test_campaign_report.py; the module fixture above draws a six-layout one's)."""
    monkeypatch.setattr(markdown, "draw_figures", lambda fd, out, r=None: {k: out / f"{k}.png" for k in CAPTIONS})
    _campaign(tmp_path, layouts=1)
    text = build_report(tmp_path).read_text(encoding="utf-8")
    assert "## Too small to score against the paper" in text
    assert "## Our numbers next to the paper's" not in text and "Table II" not in text
