"""The report of a UAV campaign: the paper's Figures 5-10 and Table II, our numbers next to the published ones,
and (for a campaign with a ``design:``) which factors flip each finding.

``cosim-master report`` calls :func:`uav_report` through the ``uav`` scenario kind (``uavstudy.campaign_kind``)
for a campaign whose table has per-UAV rows; the markdown helpers are the generic report's
(``master.campaign.report``), the blocked statistics ``master.campaign.blocked``.

Units and statistics (95 % two-sided everywhere):

* the *run* is the unit: its UAVs share the wind and the layout and can collide with each other, so they are
  not independent replicates.  Per-run values: successful missions, mean remaining battery of its UAVs,
  distance, photos, UAVs removed by collisions;
* a *configuration* (cell) is a parameter set without the repetition; a *block* is a configuration without
  the strategy plus the repetition: in a campaign ``paired: [strategy]`` the A run and the B run of a block
  share their seed (wind, layout).  A vs B is the mean over blocks of the B - A difference, with the
  stratified t interval (strata: configurations; never one variance over unlike configurations), the block
  bootstrap interval and the sign-flip permutation p-value, and d_z;
* levels (the bars of Figs. 5, 6, 7, 8, 10) pool configurations: their intervals are stratified the same way
  (within-configuration variance only), weighted by UAV missions where the paper averages over missions;
* the effect of wind is measured inside a configuration: the difference between a run at wind probability w
  and the run of the same configuration and repetition at 0 % (Figs. 7b, 8b), and the within-configuration
  slope per %-point of wind probability;
* "agrees" compares values where the paper gives them, with a stated tolerance around our interval, and
  directions (with the blocked test) where it gives only a direction.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from master.campaign import blocked as bl
from master.campaign import stats as st
from master.campaign.report import campaign_facts, failures_md, md_table
from master.campaign.spec import canonical_json, design_roles

from .names import TOTAL_ROW, UAV_COLLISION, UAV_COLUMN, ZONE_COLLISION

__all__ = ["uav_report", "uav_frames", "figure_data", "table2", "paper_comparison", "pair_keys", "PAPER",
           "paper_consistency", "sensitivity_findings", "run_settings"]

COLORS = {"A": "tab:blue", "B": "tab:red"}
NO_CI = st.CI(math.nan, math.nan, math.nan, 0)
#: the grid axes of the paper's study; every other parameter is part of a configuration (rule set, factors)
STUDY_AXES = ("strategy", "n_uavs", "variant", "wind.probability")

#: the published numbers, quoted from the paper (section V)
PAPER = {
    "runs": ("336", "\"... for each possibility of wind occurrence, three simulations were performed, which "
                    "resulted in a total of 336 simulations.\""),
    "max_success": ("42, 84, 126, 168", "\"The maximum number of successes that could be obtained for the strategy "
                                        "simulations with 1, 2, 3 and 4 UAVs, respectively, were 42, 84, 126, 168.\""),
    "success_1": ("0 (A), 0 (B)", "\"It can be noted that using only 1 UAV was unsuccessful ...\""),
    "success_2": ("0 (A), > 0 (B)", "\"... and with 2 UAVs only success by strategy B.\""),
    "success_dir": ("B > A", "\"... it can be noted that strategy B was superior to strategy A.\""),
    "battery_total": ("41.07 % (A), 41.83 % (B)", "\"... the total remaining battery of the drones that used "
                                                  "Strategy B was 41.83%, against 41.07% of Strategy A.\""),
    "battery_area": ("A > B in both areas", "\"It can be observed that Strategy A, characterized by the blue color, "
                                            "was superior to Strategy B.\" (Fig. 6)"),
    "battery_wind": ("decreases with wind", "\"... the consumption increases with higher probabilities of wind "
                                            "because the drones correct their trajectories ...\" (Fig. 7)"),
    "battery_zones": ("zones > free", "\"Low battery consumption in restricted areas is justified by the high rate "
                                      "of collisions in these areas ...\""),
    "distance_total": ("~270 km (A), ~240 km (B)", "\"Strategy B was superior in this metric, with a total distance "
                                                   "traveled was about 240km. Strategy A was about 270km ...\""),
    "distance_zones": ("zones < free", "\"... in restricted areas, the distances traveled are smaller.\""),
    "distance_wind": ("increases with wind", "\"... with some exceptions, the higher the occurrence of wind, the "
                                             "greater its influence on the total distance of the flight course.\""),
    "collisions": ("215 (A), 181 (B)", "\"For this metric, Strategy A had 215 total collisions, while in Strategy B, "
                                       "there were 181.\""),
    "wall_ratio": ("zone ≈ 3 × UAV, both strategies", "\"... in the two strategies, the number of collisions occurred "
                                                      "in the wall is the triple of those between UAVs.\""),
    "battery_fleet": ("increases with fleet size, except A with 1 UAV",
                      "\"... the average of the remaining battery charge per quantity of UAVs tends to gradually "
                      "increase ... a notable exception ... Strategy A, when only one UAV was used.\" (Fig. 10)"),
    "table2": ("B better on all 8 metrics", "Table II marks Strategy A with x on every row and Strategy B with a "
                                            "check (the extracted text shows the symbols as •, ✓, /)."),
}

#: the paper's numbers that are values (not only directions): (value, tolerance, unit) -- the tolerance is
#: what we accept around our 95 % interval: 2 battery points (the paper gives two decimals but not its energy
#: law), 10 % of a distance or a count (our layout is assumed)
PAPER_VALUES = {
    "battery_A": (41.07, 2.0, "%"), "battery_B": (41.83, 2.0, "%"),
    "distance_A": (270.0, 27.0, "km"), "distance_B": (240.0, 24.0, "km"),
    "collisions_A": (215.0, 21.5, "UAVs"), "collisions_B": (181.0, 18.1, "UAVs"),
    "success_1_A": (0.0, 0.0, "missions"), "success_1_B": (0.0, 0.0, "missions"), "success_2_A": (0.0, 0.0, "missions"),
    "wall_ratio": (3.0, 1.0, "x"),
}
#: UAV missions per strategy in the paper's grid: (1 + 2 + 3 + 4) UAVs x 2 areas x 7 wind levels x 3 repetitions
PAPER_MISSIONS = 420


def paper_consistency() -> list[str]:
    """Which of the paper's numbers cannot all hold together, computed from the numbers themselves."""
    out = []
    for s, km, left, coll in (("A", 270.0, 41.07, 215), ("B", 240.0, 41.83, 181)):
        used = 100.0 - left
        per = km / PAPER_MISSIONS
        frac = coll / PAPER_MISSIONS
        # a surviving mission can use at most 95 % (forced landing): the collided ones must have used the rest
        c_min = (used - (1 - frac) * 95.0) / frac
        out.append(f"Strategy {s}: {km:.0f} km over {PAPER_MISSIONS} missions is {per:.3f} km per mission, yet "
                   f"{used:.2f} % of the battery was used on average: a whole battery would last {per / used * 100:.2f} "
                   f"km ({per / used * 100 / 5.0 * 1000 / 60:.1f} min at 5 m/s), and the 80 % return would come "
                   f"after {per / used * 80:.2f} km. With {coll} of {PAPER_MISSIONS} missions ({frac * 100:.0f} %) "
                   f"ended by a collision (more if a UAV-UAV collision, which ends two missions, counts once) and "
                   f"no mission using more than 95 %, the collided missions must have "
                   f"used at least {c_min:.1f} % each on average, which contradicts the paper's \"collisions at the "
                   f"beginning of the simulation\" (Fig. 6 text).")
    out.append("Fig. 6 says strategy A kept more battery than B in both areas, while the totals say B kept more "
               "(41.83 % against 41.07 %). Both strategies fly 210 missions in each area, so each overall mean is "
               "the average of its two area means: A ahead in both areas forces A ahead overall. The two cannot "
               "both hold.")
    out.append("215 and 181 collisions are not multiples of 4, so the wall collisions cannot be exactly three times "
               "the UAV collisions (z = 3u gives z + u = 4u); \"the triple\" can only be approximate "
               "(215 = 161 + 54: 2.98x; 181 = 136 + 45: 3.02x).")
    return out


# ============================================================================================ settings
#: scenario fields that are not settings of the rules (the layout and identity of a run)
_NOT_SETTINGS = ("name", "base", "targets", "zones", "seed", "description", "n_uavs", "strategy", "layout_seed")


def run_settings(campaign_dir: Path, run_ids, df=None) -> dict:
    """run_id -> the scalar settings of its scenario.yaml (``lookahead``, ``wind.intensities.strong``, ...),
    overlaid with the settings its summary recorded (``settings.*`` columns of the table: the values the rule
    set resolved, ``cruise_speed``, ``zone_planning``, ``wind_episode_s``, ...): what the run actually flew
    with, whatever the campaign varied."""
    import yaml
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    out = {}
    for rid in run_ids:
        p = Path(campaign_dir) / "runs" / str(rid) / "scenario.yaml"
        try:
            data = yaml.load(p.read_text(encoding="utf-8"), Loader=loader)
        except (OSError, yaml.YAMLError):
            continue
        flat: dict = {}

        def walk(d, prefix):
            for k, v in d.items():
                key = f"{prefix}{k}"
                if prefix == "" and k in _NOT_SETTINGS:
                    continue
                if isinstance(v, dict):
                    walk(v, key + ".")
                elif not isinstance(v, list):
                    flat[key] = v
        if isinstance(data, dict):
            walk(data, "")
        out[rid] = flat
    if df is not None and UAV_COLUMN in df.columns:
        cols = [c for c in df.columns if c.startswith("settings.")]
        tot = df[df[UAV_COLUMN] == TOTAL_ROW]
        for rid, row in zip(tot["run_id"], tot[cols].itertuples(index=False)):
            if rid in out or not out:
                d = out.setdefault(rid, {})
                d.update({c[len("settings."):]: _plain(v) for c, v in zip(cols, row)
                          if v is not None and not (isinstance(v, float) and math.isnan(v))})
    return out


def settings_summary(settings: dict) -> tuple[dict, dict]:
    """(constant, varying): the settings every run shares (name -> value) and the ones that differ
    (name -> sorted distinct values)."""
    keys = sorted({k for s in settings.values() for k in s} - {"layout_seed", "layout_id"})
    const, vary = {}, {}
    for k in keys:
        vals = {canonical_json(s.get(k)) for s in settings.values()}
        if len(vals) == 1:
            const[k] = next(iter(settings.values())).get(k)
        else:
            vary[k] = sorted(json.loads(v) for v in vals if v != "null")
    return const, vary


def causes(settings: dict) -> dict:
    """Why a claim can come out differently here, from the rule set the runs actually used."""
    const, vary = settings_summary(settings) if settings else ({}, {})

    def val(key, default="?"):
        if key in const:
            return f"{const[key]}"
        if key in vary:
            return " / ".join(str(v) for v in vary[key]) + " (varied)"
        return default

    zp = val("zone_planning", None)
    planning = ("legs planned around the zones (20 m margin; a rule the paper does not have)" if zp == "True"
                else "the paper's late detection only (no planning)" if zp == "False"
                else f"zone_planning = {zp}" if zp else "zone rule not recorded")
    speed = next((k for k in ("cruise_speed", "speed.cruise", "cruise.speed", "speed") if k in const or k in vary),
                 None)
    rules = f" Rule set: {val('rules')}." if ("rules" in const or "rules" in vary) else ""
    return {
        "geometry": "The paper publishes no coordinates (its Fig. 4 is a map without scale): "
                    + ("every repetition of these runs flies its own random layout (24 targets, 4 restricted zones "
                       "drawn by the rules of docs/paper_config_format.md, uavstudy/layout.py)"
                       if val("layout", "") == "random" else
                       "our 24 targets, base and 4 restricted zones are one assumed layout "
                       "(ssp/scenarios/paper_area*.yaml, docs/paper_config_format.md)")
                    + f", area scale {val('area_scale', '1')}, take-off {val('takeoff', 'ring')}; every absolute number "
                    "(distances, battery, collision counts) depends on the geometry.",
        "energy": "Our battery is a physical model (uavsim.battery: rotor power from airspeed and climb, Li-ion pack) "
                  "instead of the paper's Ptolemy Energy actor, whose consumption law is not published"
                  + (f"; cruise speed {val(speed)} m/s" if speed else "") + "." + rules,
        "wind": f"The paper's wind model is not published; these runs drew wind episodes of "
                f"{val('wind_episode_s', val('wind.decision_interval'))} s with the given probability, speeds "
                f"{val('wind.intensities.weak')}/{val('wind.intensities.moderate')}/{val('wind.intensities.strong')}"
                f" m/s from {val('wind.direction_deg')} degrees, "
                + ("one draw per UAV" if val("wind_shared", "") == "False" else
                   "one draw shared by the fleet" if val("wind_shared", "") == "True" else "shared or per UAV: ?")
                + ("; the wind pushes the UAV (displacement the controller does not cancel)"
                   if val("wind_effect", "") == "push" else
                   "; the wind is an air velocity the controller corrects" if val("wind_effect", "") == "drag"
                   else "") + ".",
        "collisions_count": "The paper does not say whether a UAV-UAV collision counts once or once per UAV; we count "
                            "removed UAVs (a UAV-UAV collision removes two).",
        "collisions_model": f"Collision detection is continuous (swept) over each step; zone detection of these runs: "
                            f"look-ahead {val('lookahead')} m, {planning}; zones of our assumed layout.",
        "success_def": "Success follows the paper: all assigned targets photographed, back at base with more than 5 % "
                       "battery; the 80 % return and 95 % forced-landing rules are applied by our strategy FMU.",
        "campaign": "This campaign is not the paper's 336-run grid.",
        "speed": f"Cruise speed of these runs: {val(speed) if speed else 'the strategy FMU default'} m/s. The paper "
                 "flies ArduCopter's default of its era (WPNAV_SPEED 500 cm/s = 5 m/s); the distance a UAV covers "
                 "before its 80 % return grows with the speed, so whether one UAV can fly the whole tour depends "
                 "on it.",
    }


# ============================================================================================ data
def _col(df, *names):
    for n in names:
        if n in df.columns:
            return n
    return None


def param_columns(df) -> list[str]:
    """The campaign's parameter columns: between run_id and rep in the table (master.campaign.table)."""
    cols = list(df.columns)
    return cols[1:cols.index("rep")] if "rep" in cols else []


def uav_frames(df):
    """(U, R): one row per UAV mission and one per run, completed runs only, with the analysis columns
    strategy, n_uavs, area, wind (probability, fraction), rep, ``config`` (the parameters besides the study axes:
    rule set, design factors), ``cell`` (the configuration without the strategy and repetition) and ``block``
    (cell + repetition: the A/B pair) and, per run, successes, battery (mean over its UAVs), distance_m, photos,
    collisions."""
    import pandas as pd
    df = df.copy()
    if UAV_COLUMN not in df.columns:
        return None, None
    done = df[df["run_outcome"] == "completed"]
    tot = done[done[UAV_COLUMN] == TOTAL_ROW].copy()
    uav = done[done[UAV_COLUMN].notna() & (done[UAV_COLUMN] != TOTAL_ROW)].copy()
    if tot.empty or uav.empty:
        return None, None
    scol = _col(tot, "strategy", "summary.strategy")
    ncol = _col(tot, "n_uavs", "uavs")
    acol = _col(tot, "variant", "scenario")
    wcol = _col(tot, "wind.probability", "wind_probability")
    params = param_columns(df)
    extra = [k for k in params if k not in STUDY_AXES]
    runs = pd.DataFrame({"run_id": tot["run_id"].to_numpy(),
                         "strategy": tot[scol].astype(str).to_numpy() if scol else "?",
                         "n_uavs": pd.to_numeric(tot[ncol]).astype(int).to_numpy() if ncol else 0,
                         "area": tot[acol].astype(str).to_numpy() if acol else "all",
                         "wind": pd.to_numeric(tot[wcol]).astype(float).to_numpy() if wcol else 0.0,
                         "rep": tot["rep"].to_numpy() if "rep" in tot.columns else 0})
    for k in extra:
        runs[k] = tot[k].to_numpy()
    if "settings.layout_id" in tot.columns:          # the layout each run flew (summary.json settings)
        runs["layout_id"] = tot["settings.layout_id"].astype(str).to_numpy()
    runs["config"] = [canonical_json({k: _plain(v) for k, v in zip(extra, row)})
                      for row in tot[extra].itertuples(index=False)] if extra else "{}"
    runs["cell"] = [f"{c}|{n}|{a}|{w:g}" for c, n, a, w in zip(runs["config"], runs["n_uavs"], runs["area"],
                                                               runs["wind"])]
    runs["block"] = runs["cell"] + "|" + runs["rep"].astype(str)
    u = uav.merge(runs, on="run_id", how="inner", suffixes=("_param", ""))
    for c in runs.columns:
        if c + "_param" in u.columns:
            u = u.drop(columns=[c + "_param"])
    u["success"] = u["success"].astype(bool) if "success" in u.columns else False
    u["remaining_battery_pct"] = pd.to_numeric(u.get("remaining_battery_pct"), errors="coerce")
    u["collision_uav"] = (u["outcome"] == UAV_COLLISION).astype(int)
    u["collision_zone"] = (u["outcome"] == ZONE_COLLISION).astype(int)
    agg = u.groupby("run_id").agg(uav_collided=("collision_uav", "sum"), zone_collided=("collision_zone", "sum"),
                                  successes=("success", "sum"), battery=("remaining_battery_pct", "mean"),
                                  first_removal_s=("removed_time", lambda s: pd.to_numeric(s, errors="coerce").min()))
    r = runs.merge(agg, on="run_id", how="left")
    tot_idx = tot.set_index("run_id")
    # the run's totals are sums over its UAVs (summary.json names them *_sum)
    r["distance_m"] = pd.to_numeric(tot_idx.loc[r["run_id"], "distance_m_sum"]).to_numpy()
    r["distance_km"] = r["distance_m"] / 1000.0
    r["photos"] = (pd.to_numeric(tot_idx.loc[r["run_id"], "photos_sum"]).to_numpy() if "photos_sum" in tot.columns
                   else np.nan)
    r["uav_collision_events"] = (pd.to_numeric(tot_idx.loc[r["run_id"], "uav_collisions"]).to_numpy()
                                 if "uav_collisions" in tot.columns else np.nan)
    r["collisions"] = r["uav_collided"] + r["zone_collided"]
    # the other reading of the paper's count: a UAV-UAV collision counted once (it removes two UAVs)
    events = r["uav_collision_events"].fillna(r["uav_collided"] // 2) if "uav_collision_events" in r else \
        r["uav_collided"] // 2
    r["collision_events"] = r["zone_collided"] + events
    r["uav_events"] = events
    return u, r


def _plain(v):
    return v.item() if hasattr(v, "item") else v


def _areas(u):
    names = list(dict.fromkeys(u["area"]))
    return sorted(names, key=lambda a: (_is_zone(a), a))


def _is_zone(area: str) -> bool:
    return "zone" in area.lower() or "restrict" in area.lower()


def area_label(area: str) -> str:
    """The paper's words: "free" and "restricted" (areas with flight restrictions)."""
    return "restricted" if _is_zone(area) else ("free" if "free" in area.lower() or area == "all" else area)


def battery_ci(values) -> st.CI:
    """Mean remaining battery with its t interval, cut to the percentages a battery can have."""
    return st.mean_ci(values, floor=0.0, ceiling=100.0)


def ratio_text(num: int, den: int) -> str:
    """num / den as "2.50×"; a zero denominator has no ratio ("both 0", or "n/a" beside a non-zero numerator)."""
    if den:
        return f"{num / den:.2f}×"
    return "both 0" if num == 0 else "n/a: none in the denominator"


def n_text(r, u=None) -> str:
    """n of a panel or table: runs, UAV missions, configurations and layouts."""
    runs = int(len(r))
    missions = int(len(u)) if u is not None else int(r["n_uavs"].sum())
    cells = int(r["cell"].nunique()) if "cell" in r.columns else 0
    if "layout_id" in r.columns:
        k = r["layout_id"].nunique()
        lay = f"{k} layout{'s' if k != 1 else ''}"
    else:
        lay = f"1 fixed layout per area ({r['area'].nunique()} area{'s' if r['area'].nunique() != 1 else ''})"
    return f"n = {runs} runs, {missions} UAV missions, {cells} configurations, {lay}"


# ============================================================================================ statistics
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


def figure_data(u, r) -> dict:
    """Every number the figures show (estimates and 95 % stratified intervals), keyed by figure."""
    strategies = sorted(set(r["strategy"]))
    fleets = sorted(set(int(x) for x in r["n_uavs"]))
    winds = sorted(set(float(x) for x in r["wind"]))
    areas = _areas(u)
    d: dict = {"strategies": strategies, "fleets": fleets, "winds": winds, "areas": areas, "n": n_text(r, u)}
    f5 = {}
    for s in strategies:
        for n in fleets:
            sub = r[(r["strategy"] == s) & (r["n_uavs"] == n)]
            k, m = int(sub["successes"].sum()), int(sub["n_uavs"].sum())
            f5[(s, n)] = (k, m, total_ci(sub, "successes", ceiling=float(m)))
    d["fig5"] = f5
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
                 for s in strategies for a in areas for kind, col in (("uav", "uav_collided"), ("zone", "zone_collided"))}
    d["fig10"] = {(s, n): level_ci(r[(r["strategy"] == s) & (r["n_uavs"] == n)], "battery", True, 0.0, 100.0)
                  for s in strategies for n in fleets}
    return d


# ============================================================================================ table II
TABLE2 = [
    # key, label, per-run column, better, wind only, aggregate shown (sum over runs | mean over missions)
    ("success", "Success per number of UAVs", "successes", "higher", False, "count"),
    ("photos", "Number of photos", "photos", "higher", False, "sum"),
    ("photos_wind", "Number of photos with wind", "photos", "higher", True, "sum"),
    ("energy", "Remaining energy", "battery", "higher", False, "mean"),
    ("energy_wind", "Remaining energy with wind", "battery", "higher", True, "mean"),
    ("distance", "Travelled distance", "distance_km", "lower", False, "sum"),
    ("distance_wind", "Travelled distance with wind", "distance_km", "lower", True, "sum"),
    ("collisions", "Number of collisions", "collisions", "lower", False, "sum"),
]


def pair_keys(df, manifest) -> dict | None:
    """run_id -> the key that matches a strategy-A run with its strategy-B twin (every other parameter and the
    repetition: the runs that share their seed in a campaign with ``paired: [strategy]``); None when the
    campaign is not paired on the strategy."""
    if "strategy" not in (manifest.get("paired") or []) or df is None or UAV_COLUMN not in df.columns:
        return None
    keys = [k for k in manifest.get("param_keys", []) if k != "strategy" and k in df.columns] + ["rep"]
    tot = df[df[UAV_COLUMN] == TOTAL_ROW]
    return {rid: canonical_json([_plain(v) for v in row])
            for rid, row in zip(tot["run_id"], tot[keys].itertuples(index=False))}


def table2(u, r, alpha: float = 0.05, pairs: dict | None = None) -> list[dict]:
    """Table II: for each metric the totals (or mission means) of A and B and the blocked comparison B - A per
    run (``ab_effect``), which decides "better".  ``pairs`` is accepted for the caller's information only:
    the blocks are the same whether or not the campaign shares seeds (it then says whether the twins met the
    same wind)."""
    rows = []
    for key, label, col, better, wind_only, shown in TABLE2:
        data = r[r["wind"] > 0] if wind_only else r
        a, b = data[data["strategy"] == "A"], data[data["strategy"] == "B"]
        row = {"key": key, "metric": label, "n_A": len(a), "n_B": len(b)}
        if shown == "count":
            ka, kb = int(a[col].sum()), int(b[col].sum())
            row.update(A=f"{ka}/{int(a['n_uavs'].sum())}", B=f"{kb}/{int(b['n_uavs'].sum())}")
        elif shown == "mean":
            row.update(A=level_ci(a, col, True).fmt(2, " %"), B=level_ci(b, col, True).fmt(2, " %"))
        else:
            unit = " km" if col == "distance_km" else ""
            row.update(A=f"{a[col].sum():.6g}{unit}", B=f"{b[col].sum():.6g}{unit}")
        e = ab_effect(data, col)
        row.update(effect=e, p=e.p, n_blocks=e.n_blocks, per_layout=per_layout(data, col))
        if not math.isfinite(e.estimate) or e.estimate == 0:
            lead = "tie"
        else:
            lead = "B" if (e.estimate > 0) == (better == "higher") else "A"
        row["lead"] = lead
        row["better"] = lead if (lead != "tie" and e.significant) else "none"
        row["sense"] = better
        rows.append(row)
    return rows


# ============================================================================================ paper comparison
def _fmt_p(p: float) -> str:
    if not math.isfinite(p):
        return "n/a"
    return f"{p:.2g}" if p >= 0.001 else f"{p:.1e}"


def _eff(e: bl.Effect, digits=2, unit="") -> str:
    return f"{e.fmt(digits, unit)}, p = {_fmt_p(e.p)}, {e.n_blocks} blocks"


def _facts(u, r, fd) -> dict:
    """Data-driven sentences that explain a comparison, keyed by claim."""
    f: dict = {}
    removed = u["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
    if len(u):
        kept = u[~removed]["remaining_battery_pct"]
        rt = u[removed]["removed_time"].astype(float)
        rb = u[removed]["remaining_battery_pct"].astype(float)
        f["battery_total"] = (f"{removed.mean() * 100:.0f} % of our UAV missions end in a collision (median at "
                              f"t = {rt.median():.0f} s, {rb.mean():.1f} % battery left on average); over the other "
                              f"missions the mean remaining battery is {kept.mean():.1f} %."
                              if removed.any() and len(kept) else "")
        f["battery_area"] = f["battery_total"]
        f["battery_zones"] = f["battery_total"]
    if len(u) and "distance_m" in u.columns:
        parts = []
        for s in sorted(set(u["strategy"])):
            sub = u[u["strategy"] == s]
            rm = sub["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
            d = sub[~rm]["distance_m"].astype(float)
            parts.append(f"{s}: {rm.mean() * 100:.0f} % of missions removed by a collision, the others flew "
                         f"{d.mean() / 1000:.2f} km on average")
        f["distance_total"] = "Per UAV mission: " + "; ".join(parts) + "."
        f["distance_wind"] = f.get("distance_wind", "")
    one = u[(u["n_uavs"] == 1) & (u["outcome"] == "success")]
    if len(one):
        cells = one.groupby(["strategy", "area"]).size()
        f["success_1"] = (f"A single UAV can fly our whole 24-target tour: {len(one)} single-UAV missions succeeded "
                          f"with {one['remaining_battery_pct'].mean():.1f} % battery left on average "
                          f"({', '.join(f'{k[0]}/{k[1]}: {v}' for k, v in cells.items())}).")
    two = u[u["n_uavs"] == 2]
    if len(two):
        oc = two.groupby("strategy")["outcome"].value_counts().unstack(fill_value=0)
        f["success_2"] = "Outcomes with 2 UAVs: " + "; ".join(
            f"{s}: " + ", ".join(f"{k} {int(v)}" for k, v in oc.loc[s].items() if v) for s in oc.index) + "."
    for s in ("A", "B"):
        sub = u[(u["strategy"] == s) & (u["outcome"] == UAV_COLLISION)]
        if len(sub):
            t = sub["removed_time"].astype(float)
            f.setdefault("wall_ratio", "")
            f["wall_ratio"] += (f"Strategy {s}: {len(sub)} UAVs removed by UAV-UAV collisions, median at "
                                f"t = {t.median():.0f} s, in fleets of "
                                f"{', '.join(str(n) for n in sorted(set(sub['n_uavs'])))} UAVs. ")
    f["collisions"] = f.get("wall_ratio", "")
    cells = r.groupby(["strategy", "n_uavs", "area"])["distance_m"].nunique()
    many = r.groupby(["strategy", "n_uavs", "area"]).size()
    idem = int(((cells == 1) & (many > 1)).sum())
    if idem and len(set(r["wind"])) > 1:
        f["battery_wind"] = (f"In {idem} of {len(cells)} (strategy, fleet, area) cells every run flew exactly the "
                             "same distance whatever its wind probability and seed: the wind did not reach the UAVs. "
                             "Check that the macro step is shorter than the wind decision interval: UavWind ramps "
                             "each wind episode up from 0 at its start, and with a step equal to the interval every "
                             "communication point falls on an episode start.")
        f["distance_wind"] = f["battery_wind"]
    return f



def paper_comparison(u, r, fd: dict, t2: list[dict], why_keys: dict | None = None) -> list[dict]:
    """One row per published claim: the paper's value, ours, ``value`` (agreement by value where the paper
    gives a number, with its tolerance), ``agree`` (the value agreement where there is one, else the
    direction), ``sig`` (our blocked test or within-configuration slope is significant), the likely causes
    and facts."""
    rows = []
    facts = _facts(u, r, fd)

    def add(key, ours, agree, why=(), note="", sig=None, value=None):
        paper, quote = PAPER[key]
        if value is not None and value.agrees is not None:
            agree = value.agrees
        agree = None if agree is None else bool(agree)
        sig = None if sig is None else bool(sig)
        rows.append({"key": key, "paper": paper, "quote": quote, "ours": ours, "agree": agree, "sig": sig,
                     "value": value, "why": list(why), "note": note, "fact": facts.get(key, "")})

    def both(v1, v2):
        """Agreement of two values (A and B): both must agree."""
        if v1.agrees is None or v2.agrees is None:
            return bl.Agreement(None, "")
        return bl.Agreement(v1.agrees and v2.agrees, f"A: {v1.text}; B: {v2.text}")

    n_runs = r["run_id"].nunique()
    add("runs", f"{n_runs} completed runs", None, () if n_runs == 336 else ("campaign",),
        value=bl.agrees_by_value(336.0, float(n_runs), 0.0))
    f5 = fd["fig5"]
    fleets = fd["fleets"]
    maxes = ", ".join(str(f5.get(("A", n), (0, 0))[1]) for n in fleets)
    add("max_success", maxes, None, () if maxes == "42, 84, 126, 168" else ("campaign",),
        value=bl.Agreement(maxes == "42, 84, 126, 168", "the UAV missions per fleet size of the grid"))

    def succ(s, n):
        k, m, ci = f5.get((s, n), (0, 0, st.CI(math.nan, math.nan, math.nan, 0)))
        return k, m, ci
    if 1 in fleets:
        (ka, ma, ca), (kb, mb, cb) = succ("A", 1), succ("B", 1)
        v = both(bl.agrees_by_value(0.0, ca, 0.0), bl.agrees_by_value(0.0, cb, 0.0))
        add("success_1", f"{ka}/{ma} (A), {kb}/{mb} (B)", None, ("speed", "geometry", "energy", "success_def"),
            value=v)
    if 2 in fleets:
        (ka, ma, ca), (kb, mb, _) = succ("A", 2), succ("B", 2)
        v = bl.agrees_by_value(0.0, ca, 0.0)
        add("success_2", f"{ka}/{ma} (A), {kb}/{mb} (B)", kb > 0 and ka == 0,
            ("speed", "geometry", "energy", "success_def"),
            value=bl.Agreement(v.agrees and kb > 0, v.text) if v.agrees is not None else None)
    srow = next(x for x in t2 if x["key"] == "success")
    add("success_dir", f"{srow['A']} (A) vs {srow['B']} (B); B - A per run {_eff(srow['effect'])}",
        None if srow["lead"] == "tie" else srow["lead"] == "B", ("geometry", "collisions_model", "speed"),
        sig=srow["effect"].significant)
    bm = {s: level_ci(r[r["strategy"] == s], "battery", True, 0.0, 100.0) for s in ("A", "B")}
    erow = next(x for x in t2 if x["key"] == "energy")
    v = both(bl.agrees_by_value(PAPER_VALUES["battery_A"][0], bm["A"], PAPER_VALUES["battery_A"][1]),
             bl.agrees_by_value(PAPER_VALUES["battery_B"][0], bm["B"], PAPER_VALUES["battery_B"][1]))
    add("battery_total", f"{bm['A'].fmt(2, ' %')} (A), {bm['B'].fmt(2, ' %')} (B); B - A {_eff(erow['effect'])}",
        bm["B"].estimate > bm["A"].estimate, ("energy", "speed", "geometry", "collisions_model"),
        "mean over UAV missions; tolerance ±2 points around our interval", sig=erow["effect"].significant, value=v)
    parts, agree, sig = [], True, True
    for a in fd["areas"]:
        e = ab_effect(r[r["area"] == a], "battery")
        parts.append(f"{area_label(a)}: A {fd['fig6'].get(('A', a), NO_CI).fmt(1)} vs B "
                     f"{fd['fig6'].get(('B', a), NO_CI).fmt(1)}; "
                     f"B - A {_eff(e, 1)}")
        agree &= e.estimate < 0
        sig &= e.significant
    add("battery_area", "; ".join(parts), agree, ("collisions_model", "geometry", "energy"), sig=sig)
    sl = wind_slope(r, "battery")
    top = max(fd["winds"])
    e_top = wind_effect(r, "battery", top) if top > 0 else None
    add("battery_wind", f"within-configuration slope (%-points per %-point of wind probability) {_eff(sl, 3)}"
                        + (f"; {top * 100:g} % vs 0 %: {_eff(e_top, 2)}" if e_top else ""),
        None if not math.isfinite(sl.estimate) else sl.estimate < 0, ("wind",),
        "direction only (the paper gives no value)", sig=sl.significant)
    zones = [a for a in fd["areas"] if _is_zone(a)]
    free = [a for a in fd["areas"] if not _is_zone(a)]
    if zones and free:
        d = r.assign(_area=np.where(r["area"].isin(zones), "zones", "free"),
                     _c=r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["wind"].astype(str))
        dd = bl.paired_differences(d, "battery", "_area", "free", "zones", ["_c", "rep"])
        e = bl.blocked_effect(dd["diff"].to_numpy(), strata=dd["_c"].to_numpy())
        add("battery_zones", f"restricted - free per run {_eff(e, 1)}", e.estimate > 0,
            ("collisions_model", "geometry"), "same configuration and repetition in both areas", sig=e.significant)
    drow = next(x for x in t2 if x["key"] == "distance")
    da, db = r[r["strategy"] == "A"]["distance_km"].sum(), r[r["strategy"] == "B"]["distance_km"].sum()
    ca_, cb_ = total_ci(r[r["strategy"] == "A"], "distance_km"), total_ci(r[r["strategy"] == "B"], "distance_km")
    v = both(bl.agrees_by_value(PAPER_VALUES["distance_A"][0], ca_, PAPER_VALUES["distance_A"][1]),
             bl.agrees_by_value(PAPER_VALUES["distance_B"][0], cb_, PAPER_VALUES["distance_B"][1]))
    add("distance_total", f"{da:.1f} km (A), {db:.1f} km (B); B - A per run {_eff(drow['effect'], 3, ' km')}",
        db < da, ("speed", "geometry", "collisions_model"), "sum over every UAV of every run; tolerance ±10 %",
        sig=drow["effect"].significant, value=v)
    if zones and free:
        d = r.assign(_area=np.where(r["area"].isin(zones), "zones", "free"),
                     _c=r["config"] + "|" + r["strategy"] + "|" + r["n_uavs"].astype(str) + "|" + r["wind"].astype(str))
        dd = bl.paired_differences(d, "distance_km", "_area", "free", "zones", ["_c", "rep"])
        e = bl.blocked_effect(dd["diff"].to_numpy(), strata=dd["_c"].to_numpy())
        add("distance_zones", f"restricted - free per run {_eff(e, 3, ' km')}", e.estimate < 0,
            ("collisions_model", "geometry"), sig=e.significant)
    sl = wind_slope(r, "distance_km")
    add("distance_wind", f"within-configuration slope (km per run per %-point of wind probability) {_eff(sl, 4)}",
        None if not math.isfinite(sl.estimate) else sl.estimate > 0, ("wind",),
        "direction only", sig=sl.significant)
    crow = next(x for x in t2 if x["key"] == "collisions")

    def counts(col):
        ra, rb = r[r["strategy"] == "A"], r[r["strategy"] == "B"]
        v = both(bl.agrees_by_value(PAPER_VALUES["collisions_A"][0], total_ci(ra, col), PAPER_VALUES["collisions_A"][1]),
                 bl.agrees_by_value(PAPER_VALUES["collisions_B"][0], total_ci(rb, col), PAPER_VALUES["collisions_B"][1]))
        return int(ra[col].sum()), int(rb[col].sum()), v
    ca, cb, v_uav = counts("collisions")
    ea, eb, v_evt = counts("collision_events")
    v = v_evt if v_evt.agrees else v_uav
    add("collisions", f"{ca} (A), {cb} (B) UAVs removed; counting a UAV-UAV collision once: {ea} (A), {eb} (B); "
                      f"B - A UAVs removed per run {_eff(crow['effect'])}", ca > cb,
        ("collisions_model", "collisions_count", "geometry"),
        f"tolerance ±10 %; UAVs removed {'agree' if v_uav.agrees else 'do not agree'}, collisions counted once per "
        f"event {'agree' if v_evt.agrees else 'do not agree'}", sig=crow["effect"].significant,
        value=bl.Agreement(v.agrees, f"UAVs removed: {v_uav.text}; events: {v_evt.text}"))
    parts, agree_uav, agree_evt = [], True, True
    for s in ("A", "B"):
        sub = r[r["strategy"] == s]
        nu, nz, ne = int(sub["uav_collided"].sum()), int(sub["zone_collided"].sum()), int(sub["uav_events"].sum())
        parts.append(f"{s}: {nz} zone vs {nu} UAVs removed by each other ({ratio_text(nz, nu)}), vs {ne} UAV-UAV "
                     f"collisions ({ratio_text(nz, ne)})")
        agree_uav &= nu > 0 and abs(nz / nu - PAPER_VALUES["wall_ratio"][0]) <= PAPER_VALUES["wall_ratio"][1]
        agree_evt &= ne > 0 and abs(nz / ne - PAPER_VALUES["wall_ratio"][0]) <= PAPER_VALUES["wall_ratio"][1]
    add("wall_ratio", "; ".join(parts), None, ("collisions_model", "geometry", "collisions_count", "wind"),
        value=bl.Agreement(agree_uav or agree_evt,
                           f"ratio within 3 ± 1 in both strategies: counting removed UAVs {'yes' if agree_uav else 'no'}"
                           f", counting collisions {'yes' if agree_evt else 'no'}"))
    parts, agree, sig = [], True, True
    for s in ("A", "B"):
        sub = r[r["strategy"] == s]
        d = sub.assign(_c=sub["config"] + "|" + sub["area"] + "|" + sub["wind"].astype(str))
        slopes, strata = [], []
        for (c, _), g in d.groupby(["_c", "rep"], sort=False):
            if g["n_uavs"].nunique() >= 2:
                slopes.append(float(np.polyfit(g["n_uavs"].to_numpy(float), g["battery"].to_numpy(float), 1)[0]))
                strata.append(c)
        e = bl.blocked_effect(slopes, strata=strata)
        means = ", ".join(f"{n}: {fd['fig10'][(s, n)].estimate:.1f}" for n in fd["fleets"] if (s, n) in fd["fig10"])
        parts.append(f"{s}: within-configuration slope (%-points per UAV) {_eff(e, 2)} (means {means})")
        agree = agree and math.isfinite(e.estimate) and e.estimate > 0
        sig = sig and e.significant
    add("battery_fleet", "; ".join(parts), agree, ("speed", "energy", "geometry", "collisions_model"), sig=sig)
    nb = sum(1 for x in t2 if x["better"] == "B")
    na = sum(1 for x in t2 if x["better"] == "A")
    lb = sum(1 for x in t2 if x["lead"] == "B")
    add("table2", f"B significantly better on {nb}, A on {na}, no significant difference on {len(t2) - nb - na} "
                  f"(B ahead, significant or not, on {lb} of {len(t2)})", nb == len(t2),
        ("geometry", "collisions_model", "speed"))
    return rows


def _verdict(c: dict) -> str:
    if c["agree"] is None:
        return "n/a"
    text = "yes" if c["agree"] else "**no**"
    text += " (value)" if c.get("value") is not None and c["value"].agrees is not None else " (direction)"
    if c["sig"] is False:
        text += ", not significant"
    return text


# ============================================================================================ sensitivity
#: the paper's findings a sensitivity campaign checks per configuration: key -> (label, test on the runs of one
#: configuration returning (holds: bool | None, evidence text))
def _finding_tests():
    def success_1(r):
        s = r[r["n_uavs"] == 1]
        if s.empty:
            return None, "no 1-UAV runs", None
        k = int(s["successes"].sum())
        return k == 0, f"{k}/{int(s['n_uavs'].sum())} single-UAV missions succeed", None

    def success_2(r):
        s = r[r["n_uavs"] == 2]
        if s.empty:
            return None, "no 2-UAV runs", None
        ka, kb = int(s[s["strategy"] == "A"]["successes"].sum()), int(s[s["strategy"] == "B"]["successes"].sum())
        return ka == 0 and kb > 0, f"2 UAVs: A {ka}, B {kb} successes", None

    def b_more(r):
        e = ab_effect(r, "successes")
        return _holds(e, +1), f"B - A successes per run {_eff(e)}", e.estimate

    def wind_battery(r):
        e = wind_slope(r, "battery")
        return _holds(e, -1), f"slope {_eff(e, 3)} %/%-pt", e.estimate

    def wind_distance(r):
        e = wind_slope(r, "distance_km")
        return _holds(e, +1), f"slope {_eff(e, 4)} km/%-pt", e.estimate

    def b_shorter(r):
        e = ab_effect(r, "distance_km")
        return _holds(e, -1), f"B - A km per run {_eff(e, 3)}", e.estimate

    def wall_ratio(r):
        ne, nz = int(r["uav_events"].sum()), int(r["zone_collided"].sum())
        return (ne > 0 and 2.0 <= nz / ne <= 4.0), f"zone {nz} vs UAV-UAV {ne} ({ratio_text(nz, ne)})", None

    def b_fewer_collisions(r):
        e = ab_effect(r, "collisions")
        return _holds(e, -1), f"B - A collisions per run {_eff(e)}", e.estimate

    return {"success_1": ("1 UAV never succeeds", success_1),
            "success_2": ("2 UAVs: only B succeeds", success_2),
            "success_dir": ("B more successes than A", b_more),
            "battery_wind": ("wind lowers the remaining battery", wind_battery),
            "distance_wind": ("wind lengthens the distance", wind_distance),
            "distance_total": ("B flies less than A", b_shorter),
            "collisions": ("B has fewer collisions than A", b_fewer_collisions),
            "wall_ratio": ("zone collisions ≈ 3 × UAV-UAV collisions (counted once)", wall_ratio)}


def _holds(e: bl.Effect, sign: int):
    """The paper's direction (sign) and significant (blocked sign-flip test)."""
    return (e.estimate * sign > 0 and e.significant) if math.isfinite(e.estimate) else None


def flip_kind(base: tuple, other: tuple) -> str:
    """How a configuration changes a finding: the statistic changes sign ("reversed"), or keeps the baseline's
    sign but loses (or gains) significance ("weakened" / "strengthened"); counts simply "changed"."""
    b, o = base[2], other[2]
    if b is None or o is None or not (math.isfinite(b) and math.isfinite(o)):
        return "changed"
    if (b > 0) != (o > 0):
        return "reversed"
    return "strengthened" if other[0] else "weakened"


def _config_label(config: str, baseline: dict) -> str:
    vals = json.loads(config)
    diff = {k: v for k, v in vals.items() if k in baseline and canonical_json(baseline[k]) != canonical_json(v)}
    return "baseline" if not diff else ", ".join(f"{k} = {v}" for k, v in diff.items())


def sensitivity_findings(r, design: dict) -> dict:
    """For a campaign with a design: per configuration (baseline, each one-at-a-time value, each factorial
    point), whether each of the paper's findings holds in it, with its evidence, and per finding the
    configurations that flip it relative to the baseline."""
    tests = _finding_tests()
    base = design["baseline"]
    configs = list(dict.fromkeys(r["config"]))
    table = {}
    for c in configs:
        sub = r[r["config"] == c]
        table[c] = {k: fn(sub) for k, (_, fn) in tests.items()}
    base_c = next((c for c in configs if "baseline" in design_roles(json.loads(c), design)), None)
    flips = {}
    for k in tests:
        b = table[base_c][k][0] if base_c else None
        flips[k] = [c for c in configs if c != base_c and table[c][k][0] is not None and b is not None
                    and table[c][k][0] != b]
    return {"tests": {k: lbl for k, (lbl, _) in tests.items()}, "table": table, "baseline": base_c,
            "flips": flips, "labels": {c: _config_label(c, base) for c in configs},
            "roles": {c: design_roles(json.loads(c), design) for c in configs}}


def sensitivity_md(r, design: dict) -> list[str]:
    sf = sensitivity_findings(r, design)
    L = ["## Sensitivity: which assumptions flip which finding", "",
         f"One factor at a time around the baseline ({', '.join(f'{k} = {v}' for k, v in design['baseline'].items())})"
         + (f", plus the factorial {' x '.join(f'{k} {v}' for k, v in design['factorial'].items())}"
            if design.get("factorial") else "")
         + f". Each configuration runs the whole grid ({n_text(r[r['config'] == (sf['baseline'] or r['config'].iloc[0])])} "
           "per configuration). A finding *holds* when its statistic has the paper's sign and is significant "
           "(blocked sign-flip test, α = 0.05) or, for counts the paper gives, equals it.", ""]
    keys = list(sf["tests"])
    rows = []
    for c, res in sf["table"].items():
        rows.append([sf["labels"][c], ", ".join(x.split(":")[0] for x in sf["roles"][c]) or "-",
                     *["✓" if res[k][0] else ("✗" if res[k][0] is False else "n/a") for k in keys]])
    L += [md_table(["configuration", "design", *[sf["tests"][k] for k in keys]], rows), ""]
    L += ["Per finding, the configurations that flip it relative to the baseline (with the evidence in the "
          "flipped configuration; baseline evidence first):", ""]
    for k in keys:
        base = sf["table"][sf["baseline"]][k] if sf["baseline"] else (None, "", None)
        fl = sf["flips"][k]
        state = "holds" if base[0] else ("does not hold" if base[0] is False else "n/a")
        flipped = "; ".join(f"*{sf['labels'][c]}* ({flip_kind(base, sf['table'][c][k])}): {sf['table'][c][k][1]}"
                            for c in fl) or "no factor flips it"
        L += [f"- **{sf['tests'][k]}** — baseline {state} ({base[1]}). Flipped by: {flipped}."]
    L += [""]
    return L


# ============================================================================================ figures
def _fig(w=7.5, h=4.5, ncols=1):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(w, h), dpi=90)
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]
    return fig, (axes[0] if ncols == 1 else axes)


def _err(ci, scale: float = 1.0):
    if not math.isfinite(ci.low):
        return [[0.0], [0.0]]
    return [[max(0.0, (ci.estimate - ci.low) * scale)], [max(0.0, (ci.high - ci.estimate) * scale)]]


def _wind_colors(winds):
    from matplotlib.colors import LinearSegmentedColormap
    cmap = LinearSegmentedColormap.from_list("paper_wind", ["#08306b", "#2171b5", "#41b6c4", "#41ab5d", "#00441b"])
    n = max(1, len(winds) - 1)
    return {w: cmap(i / n) for i, w in enumerate(winds)}


def _note(ax, text: str, below: float = 42) -> None:
    """n of the panel, ``below`` points under the axis (clear of its tick labels and x-axis label)."""
    ax.annotate(text, (0.5, 0.0), xycoords="axes fraction", xytext=(0, -below), textcoords="offset points",
                ha="center", va="top", fontsize=7, color="dimgray", annotation_clip=False)


def _headroom_legend(ax, n: int) -> None:
    """The wind-probability legend in one row above the bars (room made for it), never over them."""
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + 0.22 * (high - low))
    ax.legend(title="wind probability", fontsize=7, title_fontsize=7, ncol=n, loc="upper center",
              columnspacing=0.8, handlelength=1.2)


def _pairs_note(effects: dict) -> str:
    n = sorted({e.n_blocks for e in effects.values()})
    if not n:
        return "one wind probability: no pairs"
    shown = f"{n[0]}" if len(n) == 1 else f"{n[0]}-{n[-1]}"
    return f"n = {shown} pairs per point (a run at w and the run of the same configuration and layout at 0 %)"


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path)
    return path


def _strategy_bars(ax, cis: dict, strategies, groups, width: float) -> None:
    """Side by side in each group, one bar per strategy with its interval (Figs. 6, 9 and 10)."""
    for i, s in enumerate(strategies):
        for j, g in enumerate(groups):
            ci = cis[(s, g)]
            x = j + (i - (len(strategies) - 1) / 2) * width
            ax.bar(x, ci.estimate if ci.n else 0, width, color=COLORS.get(s, f"C{i}"),
                   label=f"Strategy {s}" if j == 0 else None)
            if ci.n:
                ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=3)


def _effect_lines(ax, effects: dict, series, winds, label) -> None:
    """Within-configuration differences (vs 0 % wind) per wind probability, one line per series."""
    xs = [w for w in winds if w > 0]
    for i, key in enumerate(series):
        es = [effects[(*key, w) if isinstance(key, tuple) else (key, w)] for w in xs]
        y = [e.estimate for e in es]
        lo = [e.estimate - e.low if math.isfinite(e.low) else 0.0 for e in es]
        hi = [e.high - e.estimate if math.isfinite(e.high) else 0.0 for e in es]
        off = (i - (len(series) - 1) / 2) * 0.15
        ax.errorbar([x * 100 + off for x in xs], y, yerr=[lo, hi], marker="o", ms=4, capsize=2, lw=1,
                    label=label(key), color=COLORS.get(key[0] if isinstance(key, tuple) else key, f"C{i}"),
                    ls="-" if not isinstance(key, tuple) or not _is_zone(key[1]) else "--")
    ax.axhline(0.0, color="gray", lw=0.8)
    ax.set_xlabel("wind probability [%]")


def draw_figures(fd: dict, out: Path, r=None) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    S, N, W, A = fd["strategies"], fd["fleets"], fd["winds"], fd["areas"]
    n_all = fd["n"]
    files = {}
    width = 0.8 / max(1, len(S))
    colors = _wind_colors(W)
    # -- Fig. 5
    fig, ax = _fig()
    for i, s in enumerate(S):
        for j, n in enumerate(N):
            k, m, ci = fd["fig5"][(s, n)]
            x = j + (i - (len(S) - 1) / 2) * width
            ax.bar(x, k, width, color=COLORS.get(s, f"C{i}"), label=f"Strategy {s}" if j == 0 else None)
            if m:
                ax.errorbar(x, k, yerr=_err(ci), fmt="none", ecolor="black", capsize=3)
    ax.set_xticks(np.arange(len(N)), [f"{n}\n(of {fd['fig5'][(S[0], n)][1]})" for n in N])
    ax.set_xlabel("UAVs in the fleet (maximum successes)")
    ax.set_ylabel("successful UAV missions")
    ax.set_title("Fig. 5 - successes per fleet size (95 % stratified interval)")
    ax.legend()
    _note(ax, n_all, 56)
    files["fig5"] = _save(fig, out / "fig5_success_per_fleet_size.png")
    # -- Fig. 6
    fig, ax = _fig()
    _strategy_bars(ax, fd["fig6"], S, A, width)
    ax.set_xticks(np.arange(len(A)), [area_label(a) for a in A])
    ax.set_xlabel("area")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 6 - remaining battery per area (95 % stratified interval)")
    ax.legend()
    _note(ax, n_all)
    files["fig6"] = _save(fig, out / "fig6_battery_per_area.png")
    # -- Fig. 7: levels, and the within-configuration differences to 0 % wind
    fig, (ax, bx) = _fig(12, 4.8, 2)
    groups = [(s, a) for s in S for a in A]
    bw = 0.85 / max(1, len(W))
    for g, (s, a) in enumerate(groups):
        for k, w in enumerate(W):
            ci = fd["fig7"][(s, a, w)]
            x = g + (k - (len(W) - 1) / 2) * bw
            ax.bar(x, ci.estimate if ci.n else 0, bw, color=colors[w], label=f"{w * 100:g} %" if g == 0 else None)
            if ci.n:
                ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(groups)), [f"{s} / {area_label(a)}" for s, a in groups])
    ax.set_xlabel("strategy / area")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 7a - remaining battery per wind probability", fontsize=10)
    _headroom_legend(ax, len(W))
    _note(ax, n_all)
    if fd["fig7b"]:
        _effect_lines(bx, fd["fig7b"], groups, W, lambda k: f"{k[0]} / {area_label(k[1])}")
        bx.legend(fontsize=7)
    bx.set_ylabel("battery at w minus at 0 % [%-points]")
    bx.set_title("Fig. 7b - same configuration and repetition, paired (95 % interval)", fontsize=10)
    _note(bx, _pairs_note(fd["fig7b"]))
    files["fig7"] = _save(fig, out / "fig7_battery_per_wind.png")
    # -- Fig. 8
    fig, (ax, bx) = _fig(12, 4.8, 2)
    for g, s in enumerate(S):
        for k, w in enumerate(W):
            ci = fd["fig8"][(s, w)]
            x = g + (k - (len(W) - 1) / 2) * bw
            ax.bar(x, ci.estimate, bw, color=colors[w], label=f"{w * 100:g} %" if g == 0 else None)
            ax.errorbar(x, ci.estimate, yerr=_err(ci), fmt="none", ecolor="black", capsize=1.5, lw=0.8)
    ax.set_xticks(np.arange(len(S)), [f"Strategy {s}" for s in S])
    ax.set_xlabel("strategy")
    ax.set_ylabel("total distance flown [km]")
    ax.set_title("Fig. 8a - total distance per wind probability", fontsize=10)
    _headroom_legend(ax, len(W))
    _note(ax, n_all)
    if fd["fig8b"]:
        _effect_lines(bx, fd["fig8b"], S, W, lambda k: f"Strategy {k}")
        bx.legend(fontsize=7)
    bx.set_ylabel("distance per run at w minus at 0 % [km]")
    bx.set_title("Fig. 8b - same configuration and repetition, paired (95 % interval)", fontsize=10)
    _note(bx, _pairs_note(fd["fig8b"]))
    files["fig8"] = _save(fig, out / "fig8_distance_per_wind.png")
    # -- Fig. 9, one panel per area
    fig, axes = _fig(5 * len(A), 4.5, len(A))
    axes = axes if isinstance(axes, list) else [axes]
    kinds = [("uav", "UAV"), ("zone", "restricted area (wall)")]
    for ax, a in zip(axes, A):
        _strategy_bars(ax, {(s, kind): fd["fig9"][(s, a, kind)] for s in S for kind, _ in kinds}, S,
                       [kind for kind, _ in kinds], width)
        ax.set_xticks(np.arange(len(kinds)), [label for _, label in kinds])
        ax.set_xlabel("impact point")
        ax.set_ylabel("UAVs removed by a collision")
        ax.set_title(f"Fig. 9 - {area_label(a)} area (95 % interval)", fontsize=10)
        ax.legend()
        if r is not None:
            _note(ax, n_text(r[r["area"] == a]))
    files["fig9"] = _save(fig, out / "fig9_collisions_per_impact.png")
    # -- Fig. 10
    fig, ax = _fig()
    _strategy_bars(ax, fd["fig10"], S, N, width)
    ax.set_xticks(np.arange(len(N)), [str(n) for n in N])
    ax.set_xlabel("UAVs in the fleet")
    ax.set_ylabel("mean remaining battery per UAV [%]")
    ax.set_title("Fig. 10 - remaining battery per fleet size (95 % stratified interval)")
    ax.legend()
    _note(ax, n_all)
    files["fig10"] = _save(fig, out / "fig10_battery_per_fleet_size.png")
    return files


# ============================================================================================ markdown
def uav_report(manifest, df, out: Path) -> str | None:
    """The markdown of the report (figures written into ``out``); None when no UAV mission completed."""
    u, r = uav_frames(df)
    if u is None:
        return None
    design = manifest.get("design") or {}
    settings = run_settings(Path(out).parent, r["run_id"], df)
    why_text = causes(settings)
    L = [f"# Campaign report: {manifest['name']}", ""]
    L += [f"- {x}" for x in campaign_facts(manifest, df)]
    L += [f"- Analysed: {n_text(r, u)}."]
    const, vary = settings_summary(settings) if settings else ({}, {})
    if const:
        L += ["- Settings every run flew with (its scenario.yaml and the settings its summary recorded): "
              + ", ".join(f"`{k}` = {v}" for k, v in const.items()) + "."]
    if vary:
        L += ["- Settings that differ between runs: " + ", ".join(f"`{k}` in {v}" for k, v in vary.items()) + "."]
    paired = "strategy" in (manifest.get("paired") or [])
    L += ["", "Statistics: the run is the unit (its UAVs share wind and layout). A vs B is compared inside blocks "
              "(same configuration and repetition" + (", same seed: same wind and layout" if paired else
                                                       "; the campaign is not paired, so the seeds differ")
              + "): the mean B - A difference per run with a t interval stratified by configuration, the block "
              "bootstrap interval and the sign-flip permutation p-value. Levels pooled over configurations "
              "carry stratified intervals (within-configuration variance only). Wind effects are differences "
              "inside a configuration and repetition against its 0 % run. Every figure and table states n "
              "(runs, UAV missions, configurations, layouts).", ""]
    if design:
        L += sensitivity_md(r, design)
        base = r[r["config"] == next((c for c in dict.fromkeys(r["config"])
                                      if "baseline" in design_roles(json.loads(c), design)), r["config"].iloc[0])]
        L += ["The figures and tables below are the baseline configuration's.", ""]
        u = u[u["run_id"].isin(set(base["run_id"]))]
        r = base
    fd = figure_data(u, r)
    files = draw_figures(fd, out, r)
    t2 = table2(u, r)
    cmp_rows = paper_comparison(u, r, fd, t2)
    L += ["## Our numbers next to the paper's", "", f"{fd['n']}.", ""]
    rows = [[c["key"], c["paper"], c["ours"], _verdict(c)] for c in cmp_rows]
    L += [md_table(["quantity", "paper", "ours", "agrees"], rows), ""]
    L += ["\"agrees (value)\": the paper's number lies within our 95 % interval widened by the stated tolerance "
          "(2 battery points; 10 % of a distance or a collision count; exact for the paper's zero success counts; "
          "wall/UAV ratio 3 ± 1). \"agrees (direction)\": the paper gives only a direction. \"not significant\": "
          "our blocked test or within-configuration slope has p >= 0.05.", "", "Quotes (paper, section V):", ""]
    L += [f"- *{c['key']}*: {c['quote']}" + (f" — {c['note']}" if c["note"] else "")
          + (f" — {c['value'].text}" if c.get("value") is not None and c["value"].text else "") for c in cmp_rows]
    L += ["", "## The paper's numbers that cannot all hold together", ""]
    L += [f"- {x}" for x in paper_consistency()]
    L += ["", "## Where and why we differ", ""]
    diff = [c for c in cmp_rows if c["agree"] is False or c["sig"] is False]
    if not diff:
        L += ["Every published claim is reproduced.", ""]
    used: list[str] = []
    for c in diff:
        refs = []
        for w in c["why"]:
            if w in why_text and w not in used:
                used.append(w)
            if w in why_text:
                refs.append(f"[{used.index(w) + 1}]")
        verdict = "differs" if c["agree"] is False else "same direction, not significant here"
        L += [f"- **{c['key']}** ({verdict}) — paper: {c['paper']}; ours: {c['ours']}. {c['fact']} "
              f"Possible causes: {' '.join(refs) or '-'}"]
    if used:
        L += ["", "Causes (stated from the settings these runs used):", ""]
        L += [f"{i + 1}. {why_text[w]}" for i, w in enumerate(used)]
    L += ["", _diagnostics(u, r), ""]
    L += ["## Figures", ""]
    captions = {"fig5": "Fig. 5: successful UAV missions per fleet size and strategy",
                "fig6": "Fig. 6: mean remaining battery per area",
                "fig7": "Fig. 7: mean remaining battery per wind probability, by strategy and area; right: the "
                        "paired difference to the same configuration at 0 %",
                "fig8": "Fig. 8: total distance flown per wind probability; right: the paired difference per run",
                "fig9": "Fig. 9: collisions per impact point, per area",
                "fig10": "Fig. 10: mean remaining battery per fleet size"}
    for k, p in files.items():
        L += [f"![{captions[k]}]({p.name})", "", f"*{captions[k]}. {fd['n']}.*", ""]
    L += ["### Successes per fleet size (Fig. 5)", ""]
    rows = []
    for n in fd["fleets"]:
        row = [n]
        for s in fd["strategies"]:
            k, m, ci = fd["fig5"][(s, n)]
            row.append(f"{k}/{m} [{ci.low:.1f}, {ci.high:.1f}]" if m and math.isfinite(ci.low) else f"{k}/{m}")
        if {"A", "B"} <= set(fd["strategies"]):
            e = ab_effect(r[r["n_uavs"] == n], "successes")
            row.append(_eff(e))
        rows.append(row)
    L += [md_table(["UAVs", *[f"Strategy {s}" for s in fd["strategies"]], "B - A successes per run"], rows), ""]
    L += [f"### Remaining battery (Figs. 6, 7, 10), mean % over UAV missions [95 % stratified interval]", ""]
    rows = [[s, area_label(a), fd["fig6"][(s, a)].fmt(1)] for s in fd["strategies"] for a in fd["areas"]]
    L += [md_table(["strategy", "area", "remaining battery"], rows), ""]
    rows = [[s, area_label(a)] + [fd["fig7"][(s, a, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]
            for a in fd["areas"]]
    L += [md_table(["strategy", "area", *[f"wind probability {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    if fd["fig7b"]:
        rows = [[s, area_label(a)] + [_eff(fd["fig7b"][(s, a, w)]) for w in fd["winds"] if w > 0]
                for s in fd["strategies"] for a in fd["areas"]]
        L += ["Paired difference to 0 % wind (same configuration and repetition), %-points:", "",
              md_table(["strategy", "area", *[f"{w * 100:g} %" for w in fd["winds"] if w > 0]], rows), ""]
    rows = [[s] + [fd["fig10"][(s, n)].fmt(1) for n in fd["fleets"]] for s in fd["strategies"]]
    L += [md_table(["strategy", *[f"{n} UAV" for n in fd["fleets"]]], rows), ""]
    L += ["### Total distance (Fig. 8), km [95 % stratified interval]", ""]
    rows = [[s] + [fd["fig8"][(s, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]]
    L += [md_table(["strategy", *[f"wind probability {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    L += ["### Collisions per impact point (Fig. 9), UAVs removed [95 % interval]", ""]
    rows = [[s, area_label(a), fd["fig9"][(s, a, "uav")].fmt(0), fd["fig9"][(s, a, "zone")].fmt(0)]
            for s in fd["strategies"] for a in fd["areas"]]
    L += [md_table(["strategy", "area", "UAV-UAV", "restricted area (wall)"], rows), ""]
    L += ["## Table II - which strategy is better (α = 0.05)", "", f"{fd['n']}.", ""]
    verdict = [x["better"] if x["better"] != "none" else f"no significant difference ({x['lead']} ahead)"
               for x in t2]
    rows = [[x["metric"], x["A"], x["B"], x["effect"].fmt(3),
             f"[{x['effect'].boot_low:.3g}, {x['effect'].boot_high:.3g}]" if x["n_blocks"] else "n/a",
             f"{x['effect'].d_z:.2f}" if math.isfinite(x["effect"].d_z) else "n/a", _fmt_p(x["p"]), x["n_blocks"],
             ", ".join(f"{x:+.3g}" for x in x["per_layout"]) or "n/a", v, "B"] for x, v in zip(t2, verdict)]
    L += [md_table(["metric", "Strategy A", "Strategy B", "B - A per run [t interval]", "bootstrap interval",
                    "d_z", "sign-flip p", "blocks", "B - A per repetition (layout)", "better (ours)", "paper"],
                   rows), ""]
    n_rep = r["rep"].nunique()
    L += [f"The blocks are {r['cell'].nunique()} configurations x {n_rep} "
          f"repetitions; the repetitions are the layouts, shared by every configuration, so the p-values are "
          f"conditional on these {n_rep} layouts. A claim about layouts in general rests on the per-layout column: "
          f"with {n_rep} layouts, a sign-flip test over layouts cannot go below p = {2 / 2 ** n_rep:.2g}, so it "
          "needs the same sign in every layout at least.", ""]
    L += ["Direction: more successes, photos and remaining energy are better; less distance and fewer collisions "
          "are better (the paper's reading). \"with wind\" rows use the runs with a wind probability above 0.", ""]
    L += ["## Failed runs", "", failures_md(df)]
    return "\n".join(L)


def _diagnostics(u, r) -> str:
    """Facts from our runs that explain the comparison (outcome mix, when collisions happen)."""
    import pandas as pd
    lines = ["Mission outcomes of our UAV missions (per strategy and area):", ""]
    tab = u.groupby(["strategy", "area", "outcome"]).size().unstack(fill_value=0)
    header = ["strategy", "area", *[str(c) for c in tab.columns]]
    rows = [[s, a, *[int(v) for v in tab.loc[(s, a)].to_numpy()]] for s, a in tab.index]
    lines += [md_table(header, rows), ""]
    rem = pd.to_numeric(u["removed_time"], errors="coerce") if "removed_time" in u.columns else None
    if rem is not None and rem.notna().any():
        parts = []
        for s in sorted(set(u["strategy"])):
            x = rem[(u["strategy"] == s) & rem.notna()]
            if len(x):
                parts.append(f"{s}: {len(x)} removals, median at t = {x.median():.0f} s, "
                             f"{(x <= 120).mean() * 100:.0f} % within the first 2 min")
        lines += ["When collisions happen (simulation time of the removal): " + "; ".join(parts) + ".", ""]
    if "outcome" in u.columns:
        t = (u["outcome"] == "timeout").sum()
        if t:
            lines += [f"**{t} UAV mission(s) were still flying at the stop time** (outcome timeout): the campaign's "
                      "stop time is too short for them.", ""]
    return "\n".join(lines)
