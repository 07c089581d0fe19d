"""The estimators of the report: every interval, paired difference, slope and ratio the figures, Table II and the
findings rest on (95 % two-sided everywhere).

The **layout** is the unit of replication.  With ``layout: random`` every repetition flies its own random area,
shared by every cell of that repetition (both strategies, every fleet size, area and wind probability): the runs
of one layout share its geometry and are not independent, the layouts are.  So every statistic here is computed
in two steps:

1. one value per layout, from the runs of that layout only: a level (mean over its UAV missions, or its total),
   a paired difference averaged over the layout's pairs (B - A of the same cell; restricted - free, wind w - 0 %,
   fleet n2 - n1 of the same configuration), a within-configuration slope averaged over the layout's series;
2. the mean of those values over the layouts with the t interval (df = layouts - 1) and the matching t-test
   (:func:`master.campaign.stats.layout_t`); a ratio of totals with Fieller's interval, which inverts the same
   t-test (:func:`master.campaign.stats.layout_ratio`).

Interval and p-value therefore come from one method and cannot disagree.  A campaign without random layouts
(one fixed area) has its repetitions as the replicates; they share the area, so its intervals say nothing about
other areas.  What a statistic *means* for the paper's claims is decided in :mod:`.findings`.

These functions take the per-run frame of :func:`.tables.uav_frames` (any subset of it: one strategy, one
configuration) and are reused by other campaigns' reports (e.g. a strategy C campaign): ``ab_effect(r, col,
a="A", b="C")``.
"""
from __future__ import annotations

import numpy as np

from master.campaign import blocked as bl
from master.campaign import stats as st

from .paper_values import PAPER_MISSIONS, PAPER_REPETITIONS
from .tables import areas_in_order, is_zone
from .text import n_text

__all__ = ["NO_CI", "level_ci", "paper_grid_total", "per_mission_total", "ab_effect", "wind_effect", "wind_slope",
           "area_effect", "fleet_step", "fleet_slope", "ratio_ci", "by_layout", "figure_data", "n_layouts"]

NO_CI = st.LayoutCI(float("nan"), float("nan"), float("nan"), float("nan"), 0, {}, None)


def n_layouts(r) -> int:
    """The independent replicates of these runs (layouts; repetitions of a fixed area)."""
    return int(r["layout"].nunique()) if len(r) else 0


def by_layout(r, fn) -> dict:
    """layout -> fn(runs of that layout)."""
    return {k: fn(g) for k, g in r.groupby("layout", sort=True)}


def _mean(g, value: str, by_missions: bool) -> float:
    v = g[value].to_numpy(float)
    ok = np.isfinite(v)
    if not ok.any():
        return float("nan")
    w = g["n_uavs"].to_numpy(float)[ok] if by_missions else None
    return float(np.average(v[ok], weights=w))


def level_ci(r, value: str, by_missions: bool = False, floor=None, ceiling=None) -> st.LayoutCI:
    """Mean of a per-run value (``by_missions``: over UAV missions, each run weighted by its UAVs, as the paper
    averages) per layout, then over layouts: a level, no test."""
    return st.layout_t(by_layout(r, lambda g: _mean(g, value, by_missions)), None, floor=floor, ceiling=ceiling)


def paper_grid_total(r, value: str, ceiling=None) -> st.LayoutCI:
    """Total of a per-run value per layout, expressed per three layouts: the size of the paper's grid (three
    repetitions of each grid point, 336 runs), so a bar or a total reads against the paper's."""
    return st.layout_t(by_layout(r, lambda g: float(g[value].sum())), None, scale=PAPER_REPETITIONS, floor=0.0,
                       ceiling=ceiling)


def per_mission_total(r, value: str, missions: int = PAPER_MISSIONS) -> st.LayoutCI:
    """Total of a per-run value per UAV mission, per layout, expressed per ``missions`` missions (the paper's
    420 per strategy): the paper's totals whatever the size of our grid (identical to :func:`paper_grid_total`
    on the paper's grid)."""
    return st.layout_t(by_layout(r, lambda g: float(g[value].sum() / g["n_uavs"].sum())), None, scale=missions,
                       floor=0.0)


def _paired_by_layout(r, value: str, factor: str, a, b, pair_cols: list[str], by_missions=False) -> dict:
    """layout -> mean over the layout's pairs (same ``pair_cols``) of value(b) - value(a); ``by_missions``
    weights each pair by its UAVs (the difference of the two mission means)."""
    cols = ["layout", *pair_cols] + (["n_uavs"] if by_missions and "n_uavs" not in pair_cols else [])
    d = bl.paired_differences(r, value, factor, a, b, cols)
    if not len(d):
        return {}
    d = d[np.isfinite(d["diff"].to_numpy(float))]
    if by_missions:
        return {k: float(np.average(g["diff"], weights=g["n_uavs"].astype(float)))
                for k, g in d.groupby("layout", sort=True)}
    return {k: float(v) for k, v in d.groupby("layout", sort=True)["diff"].mean().items()}


def ab_effect(r, value: str, by_missions: bool = False, a: str = "A", b: str = "B") -> st.LayoutCI:
    """Strategy b - a per run: in each layout the mean over its cells (same configuration, fleet, area, wind;
    the same seed in a campaign paired on the strategy) of the paired difference, then over layouts with the t
    interval and t-test."""
    return st.layout_t(_paired_by_layout(r, value, "strategy", a, b, ["cell"], by_missions))


def _wind_cell(r):
    """The configuration without the wind probability (strategy included)."""
    return r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["area"]


def wind_effect(r, value: str, w: float) -> st.LayoutCI:
    """Value at wind probability ``w`` minus at 0 %, same configuration and layout."""
    d = r.assign(_wcell=_wind_cell(r))
    return st.layout_t(_paired_by_layout(d, value, "wind", 0.0, w, ["_wcell"]))


def _slope_by_layout(r, x: str, value: str, series: list[str], x_scale: float = 1.0) -> dict:
    """layout -> mean over the layout's series (``series`` columns) of the least-squares slope of value on x."""
    out: dict = {}
    for (layout, *_), g in r.groupby(["layout", *series], sort=True):
        xs, ys = g[x].to_numpy(float) * x_scale, g[value].to_numpy(float)
        ok = np.isfinite(ys)
        if ok.sum() >= 2 and np.ptp(xs[ok]) > 0:
            out.setdefault(layout, []).append(float(np.polyfit(xs[ok], ys[ok], 1)[0]))
    return {k: float(np.mean(v)) for k, v in out.items()}


def wind_slope(r, value: str) -> st.LayoutCI:
    """Within-configuration slope per %-point of wind probability: one least-squares slope per (configuration,
    layout) series over the wind levels, averaged in the layout, then over layouts."""
    d = r.assign(_wcell=_wind_cell(r))
    return st.layout_t(_slope_by_layout(d, "wind", value, ["_wcell"], 100.0))


def area_effect(r, value: str, zones: list) -> st.LayoutCI:
    """Restricted minus free area per run, same configuration, strategy, fleet, wind and layout."""
    d = r.assign(_area=np.where(r["area"].isin(zones), "zones", "free"),
                 _c=r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["wind"].astype(str))
    return st.layout_t(_paired_by_layout(d, value, "_area", "free", "zones", ["_c"]))


def _fleet_cell(r):
    return r["config"] + "|" + r["strategy"] + "|" + r["area"] + "|" + r["wind"].astype(str)


def fleet_step(r, value: str, n1: int, n2: int) -> st.LayoutCI:
    """Value with ``n2`` UAVs minus with ``n1``, same configuration, strategy, area, wind and layout."""
    d = r.assign(_f=_fleet_cell(r))
    return st.layout_t(_paired_by_layout(d, value, "n_uavs", n1, n2, ["_f"]))


def fleet_slope(r, value: str) -> st.LayoutCI:
    """Within-configuration slope per UAV of the fleet, averaged in the layout, then over layouts."""
    d = r.assign(_f=_fleet_cell(r))
    return st.layout_t(_slope_by_layout(d, "n_uavs", value, ["_f"]))


def ratio_ci(r, num: str, den: str, null: float | None = 1.0) -> st.LayoutCI:
    """sum(num) / sum(den) over the runs, with Fieller's interval over the layouts' totals (and the t-test of
    the ratio against ``null``)."""
    return st.layout_ratio(by_layout(r, lambda g: float(g[num].sum())),
                           by_layout(r, lambda g: float(g[den].sum())), null)


def figure_data(u, r) -> dict:
    """Every number the figures show (estimates and 95 % intervals over layouts), keyed by figure.  Counts and
    distances are per three layouts (the paper's grid, 336 runs), so the bars read against the paper's."""
    strategies = sorted(set(r["strategy"]))
    fleets = sorted(set(int(x) for x in r["n_uavs"]))
    winds = sorted(set(float(x) for x in r["wind"]))
    areas = areas_in_order(u)
    d: dict = {"strategies": strategies, "fleets": fleets, "winds": winds, "areas": areas, "n": n_text(r, u),
               "layouts": n_layouts(r)}
    scale = PAPER_REPETITIONS / max(1, d["layouts"])
    successes = {}
    for s in strategies:
        for n in fleets:
            sub = r[(r["strategy"] == s) & (r["n_uavs"] == n)]
            k, missions = int(sub["successes"].sum()), int(sub["n_uavs"].sum())
            successes[(s, n)] = (k, missions, paper_grid_total(sub, "successes", ceiling=missions * scale))
    d["fig5"] = successes
    d["fig6"] = {(s, a): level_ci(r[(r["strategy"] == s) & (r["area"] == a)], "battery", True, 0.0, 100.0)
                 for s in strategies for a in areas}
    d["fig7"] = {(s, a, w): level_ci(r[(r["strategy"] == s) & (r["area"] == a) & (r["wind"] == w)], "battery",
                                     True, 0.0, 100.0)
                 for s in strategies for a in areas for w in winds}
    d["fig7b"] = {(s, a, w): wind_effect(r[(r["strategy"] == s) & (r["area"] == a)], "battery", w)
                  for s in strategies for a in areas for w in winds if w > 0}
    d["fig8"] = {(s, w): paper_grid_total(r[(r["strategy"] == s) & (r["wind"] == w)], "distance_km")
                 for s in strategies for w in winds}
    d["fig8b"] = {(s, w): wind_effect(r[r["strategy"] == s], "distance_km", w)
                  for s in strategies for w in winds if w > 0}
    # no more UAVs can be removed than flew in those runs
    d["fig9"] = {(s, a, kind): paper_grid_total(r[(r["strategy"] == s) & (r["area"] == a)], col,
                                                ceiling=float(r[(r["strategy"] == s) & (r["area"] == a)]
                                                              ["n_uavs"].sum()) * scale)
                 for s in strategies for a in areas
                 for kind, col in (("uav", "uav_collided"), ("zone", "zone_collided"))}
    d["fig9_ratio"] = {s: ratio_ci(r[r["strategy"] == s], "zone_collided", "uav_collided") for s in strategies}
    d["fig10"] = {(s, n): level_ci(r[(r["strategy"] == s) & (r["n_uavs"] == n)], "battery", True, 0.0, 100.0)
                  for s in strategies for n in fleets}
    d["zones"] = [a for a in areas if is_zone(a)]
    return d
