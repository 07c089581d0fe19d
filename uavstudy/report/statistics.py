"""The estimators of the report: every interval, paired difference and slope the figures, Table II and the
findings rest on (95 % two-sided everywhere).

* the *run* is the unit: its UAVs share the wind and the layout and can collide with each other, so they are
  not independent replicates;
* a *configuration* (cell) is a parameter set without the repetition; a *block* is a configuration without
  the strategy plus the repetition (in a campaign ``paired: [strategy]`` the A and B runs of a block share
  their seed).  A vs B is the mean over blocks of the B - A difference, stratified by configuration (never one
  variance over unlike configurations), with the block bootstrap interval and the sign-flip p-value
  (``master.campaign.blocked``);
* levels pool configurations with stratified intervals (within-configuration variance only), weighted by UAV
  missions where the paper averages over missions;
* the effects of wind, of the area and of the fleet size are measured inside a configuration and repetition:
  paired differences and within-configuration slopes.

What a statistic *means* for the paper's claims (its sign, its significance, the tolerances) is decided in
:mod:`.findings`.
"""
from __future__ import annotations

import math

import numpy as np

from master.campaign import blocked as bl
from master.campaign import stats as st

from .tables import areas_in_order
from .text import n_text

__all__ = ["NO_CI", "battery_ci", "level_ci", "total_ci", "per_layout", "ab_effect", "wind_effect", "wind_slope",
           "area_effect", "fleet_slope", "figure_data"]

NO_CI = st.CI(math.nan, math.nan, math.nan, 0)


def battery_ci(values) -> st.CI:
    """Mean remaining battery with its t interval, cut to the percentages a battery can have."""
    return st.mean_ci(values, floor=0.0, ceiling=100.0)


def level_ci(r, value: str, by_missions: bool = False, floor=None, ceiling=None) -> st.CI:
    """Mean of a per-run value over the runs ``r`` with the stratified interval (strata: configurations);
    ``by_missions``: weighted by UAVs per run (the mean over UAV missions, as the paper averages)."""
    return bl.stratified_mean_ci(r[value], r["cell"], floor=floor, ceiling=ceiling,
                                 weights=r["n_uavs"] if by_missions else None)


def total_ci(r, value: str, floor=0.0, ceiling=None) -> st.CI:
    """Sum of a per-run value over the runs ``r``: n x the stratified interval of the mean."""
    c = bl.stratified_mean_ci(r[value], r["cell"], floor=floor)
    n = len(r)
    if n == 0:
        return st.CI(0.0, math.nan, math.nan, 0)
    low, high = c.low * n, c.high * n
    if ceiling is not None and math.isfinite(high):
        high = min(ceiling, high)
    return st.CI(c.estimate * n, low, high, n)


def per_layout(r, value: str) -> list[float]:
    """B - A per run averaged within each repetition (each layout, with ``layout: random``): whether an effect
    holds in every layout, the unit a claim about layouts in general rests on."""
    d = bl.paired_differences(r, value, "strategy", "A", "B", ["cell", "block", "rep"])
    return [float(x) for x in d.groupby("rep")["diff"].mean().to_numpy()] if len(d) else []


def ab_effect(r, value: str, agg: str = "mean") -> bl.Effect:
    """B - A over blocks (same configuration and repetition; same seed in a campaign paired on the strategy),
    stratified by configuration."""
    d = bl.paired_differences(r, value, "strategy", "A", "B", ["cell", "block"], agg=agg)
    return bl.blocked_effect(d["diff"].to_numpy(), strata=d["cell"].to_numpy())


def _wind_cell(r):
    """The configuration without the wind probability (strategy included)."""
    return r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["area"]


def wind_effect(r, value: str, w: float) -> bl.Effect:
    """Value at wind probability ``w`` minus value at 0 %, same configuration and repetition, stratified."""
    d = r.assign(_wcell=_wind_cell(r))
    d = bl.paired_differences(d, value, "wind", 0.0, w, ["_wcell", "rep"])
    return bl.blocked_effect(d["diff"].to_numpy(), strata=d["_wcell"].to_numpy())


def wind_slope(r, value: str) -> bl.Effect:
    """Within-configuration slope of a per-run value per %-point of wind probability: one least-squares slope
    per (configuration, repetition) series over the wind levels, averaged with the stratified interval."""
    d = r.assign(_wcell=_wind_cell(r))
    slopes, strata = [], []
    for (cell, _), g in d.groupby(["_wcell", "rep"], sort=False):
        x, y = g["wind"].to_numpy(float) * 100.0, g[value].to_numpy(float)
        ok = np.isfinite(y)
        if ok.sum() >= 2 and np.ptp(x[ok]) > 0:
            slopes.append(float(np.polyfit(x[ok], y[ok], 1)[0]))
            strata.append(cell)
    return bl.blocked_effect(slopes, strata=strata)


def area_effect(r, value: str, zones: list) -> bl.Effect:
    """Restricted minus free area per run (``zones``: the restricted areas), same configuration, strategy,
    fleet size, wind probability and repetition in both areas, stratified."""
    d = r.assign(_area=np.where(r["area"].isin(zones), "zones", "free"),
                 _c=r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["wind"].astype(str))
    dd = bl.paired_differences(d, value, "_area", "free", "zones", ["_c", "rep"])
    return bl.blocked_effect(dd["diff"].to_numpy(), strata=dd["_c"].to_numpy())


def fleet_slope(r, value: str) -> bl.Effect:
    """Within-configuration slope of a per-run value per UAV of the fleet: one least-squares slope per
    (configuration, area, wind probability, repetition) series with at least two fleet sizes, averaged with the
    stratified interval."""
    d = r.assign(_c=r["config"] + "|" + r["area"] + "|" + r["wind"].astype(str))
    slopes, strata = [], []
    for (c, _), g in d.groupby(["_c", "rep"], sort=False):
        if g["n_uavs"].nunique() >= 2:
            slopes.append(float(np.polyfit(g["n_uavs"].to_numpy(float), g[value].to_numpy(float), 1)[0]))
            strata.append(c)
    return bl.blocked_effect(slopes, strata=strata)


def figure_data(u, r) -> dict:
    """Every number the figures show (estimates and 95 % stratified intervals), keyed by figure."""
    strategies = sorted(set(r["strategy"]))
    fleets = sorted(set(int(x) for x in r["n_uavs"]))
    winds = sorted(set(float(x) for x in r["wind"]))
    areas = areas_in_order(u)
    d: dict = {"strategies": strategies, "fleets": fleets, "winds": winds, "areas": areas, "n": n_text(r, u)}
    successes = {}
    for s in strategies:
        for n in fleets:
            sub = r[(r["strategy"] == s) & (r["n_uavs"] == n)]
            k, missions = int(sub["successes"].sum()), int(sub["n_uavs"].sum())
            successes[(s, n)] = (k, missions, total_ci(sub, "successes", ceiling=float(missions)))
    d["fig5"] = successes
    d["fig6"] = {(s, a): level_ci(r[(r["strategy"] == s) & (r["area"] == a)], "battery", True, 0.0, 100.0)
                 for s in strategies for a in areas}
    d["fig7"] = {(s, a, w): level_ci(r[(r["strategy"] == s) & (r["area"] == a) & (r["wind"] == w)], "battery",
                                     True, 0.0, 100.0)
                 for s in strategies for a in areas for w in winds}
    d["fig7b"] = {(s, a, w): wind_effect(r[(r["strategy"] == s) & (r["area"] == a)], "battery", w)
                  for s in strategies for a in areas for w in winds if w > 0}
    d["fig8"] = {(s, w): total_ci(r[(r["strategy"] == s) & (r["wind"] == w)], "distance_km")
                 for s in strategies for w in winds}
    d["fig8b"] = {(s, w): wind_effect(r[r["strategy"] == s], "distance_km", w)
                  for s in strategies for w in winds if w > 0}
    # no more UAVs can be removed than flew in those runs
    d["fig9"] = {(s, a, kind): total_ci(r[(r["strategy"] == s) & (r["area"] == a)], col,
                                        ceiling=float(r[(r["strategy"] == s) & (r["area"] == a)]["n_uavs"].sum()))
                 for s in strategies for a in areas
                 for kind, col in (("uav", "uav_collided"), ("zone", "zone_collided"))}
    d["fig10"] = {(s, n): level_ci(r[(r["strategy"] == s) & (r["n_uavs"] == n)], "battery", True, 0.0, 100.0)
                  for s in strategies for n in fleets}
    return d
