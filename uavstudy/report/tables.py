"""The campaign's results table shaped for the analysis: one row per UAV mission and one per run, with the
study's axes (strategy, fleet size, area, wind probability), the configuration, cell and block every statistic
groups by, and the per-run totals the paper counts.
"""
from __future__ import annotations

import numpy as np

from master.campaign.spec import canonical_json

from ..names import TOTAL_ROW, UAV_COLLISION, UAV_COLUMN, ZONE_COLLISION

__all__ = ["STUDY_AXES", "param_columns", "uav_frames", "plain", "areas_in_order", "is_zone", "area_label",
           "pair_keys"]

#: the grid axes of the paper's study; every other parameter is part of a configuration (rule set, factors)
STUDY_AXES = ("strategy", "n_uavs", "variant", "wind.probability")


def first_column(df, *names):
    """The first of ``names`` that is a column of ``df`` (a table written by an older version names it
    differently), or None."""
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
    completed = df[df["run_outcome"] == "completed"]
    totals = completed[completed[UAV_COLUMN] == TOTAL_ROW].copy()
    uav = completed[completed[UAV_COLUMN].notna() & (completed[UAV_COLUMN] != TOTAL_ROW)].copy()
    if totals.empty or uav.empty:
        return None, None
    strategy_col = first_column(totals, "strategy", "summary.strategy")
    fleet_col = first_column(totals, "n_uavs", "uavs")
    area_col = first_column(totals, "variant", "scenario")
    wind_col = first_column(totals, "wind.probability", "wind_probability")
    params = param_columns(df)
    config_keys = [k for k in params if k not in STUDY_AXES]
    runs = pd.DataFrame({"run_id": totals["run_id"].to_numpy(),
                         "strategy": totals[strategy_col].astype(str).to_numpy() if strategy_col else "?",
                         "n_uavs": pd.to_numeric(totals[fleet_col]).astype(int).to_numpy() if fleet_col else 0,
                         "area": totals[area_col].astype(str).to_numpy() if area_col else "all",
                         "wind": pd.to_numeric(totals[wind_col]).astype(float).to_numpy() if wind_col else 0.0,
                         "rep": totals["rep"].to_numpy() if "rep" in totals.columns else 0})
    for k in config_keys:
        runs[k] = totals[k].to_numpy()
    if "settings.layout_id" in totals.columns:          # the layout each run flew (summary.json settings)
        runs["layout_id"] = totals["settings.layout_id"].astype(str).to_numpy()
    # the unit of replication: the layout (with layout: random), else the repetition of the one fixed area
    random_layouts = "layout_id" in runs.columns and runs["layout_id"].astype(str).str.startswith("random").all()
    runs["layout"] = runs["layout_id"] if random_layouts else "rep " + runs["rep"].astype(str)
    runs["config"] = [canonical_json({k: plain(v) for k, v in zip(config_keys, row)})
                      for row in totals[config_keys].itertuples(index=False)] if config_keys else "{}"
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
    per_run = u.groupby("run_id").agg(
        uav_collided=("collision_uav", "sum"), zone_collided=("collision_zone", "sum"),
        successes=("success", "sum"), battery=("remaining_battery_pct", "mean"),
        first_removal_s=("removed_time", lambda s: pd.to_numeric(s, errors="coerce").min()))
    r = runs.merge(per_run, on="run_id", how="left")
    totals_by_run = totals.set_index("run_id")
    # the run's totals are sums over its UAVs (summary.json names them *_sum)
    r["distance_m"] = pd.to_numeric(totals_by_run.loc[r["run_id"], "distance_m_sum"]).to_numpy()
    r["distance_km"] = r["distance_m"] / 1000.0
    r["photos"] = (pd.to_numeric(totals_by_run.loc[r["run_id"], "photos_sum"]).to_numpy()
                   if "photos_sum" in totals.columns else np.nan)
    r["uav_collision_events"] = (pd.to_numeric(totals_by_run.loc[r["run_id"], "uav_collisions"]).to_numpy()
                                 if "uav_collisions" in totals.columns else np.nan)
    r["collisions"] = r["uav_collided"] + r["zone_collided"]
    # the other reading of the paper's count: a UAV-UAV collision counted once (it removes two UAVs)
    events = r["uav_collision_events"].fillna(r["uav_collided"] // 2) if "uav_collision_events" in r else \
        r["uav_collided"] // 2
    r["collision_events"] = r["zone_collided"] + events
    r["uav_events"] = events
    return u, r


def plain(v):
    """A numpy scalar as the Python value (canonical JSON and the markdown need plain values)."""
    return v.item() if hasattr(v, "item") else v


def areas_in_order(u):
    """The areas of the missions ``u``, the free ones first (the paper's order)."""
    names = list(dict.fromkeys(u["area"]))
    return sorted(names, key=lambda a: (is_zone(a), a))


def is_zone(area: str) -> bool:
    return "zone" in area.lower() or "restrict" in area.lower()


def area_label(area: str) -> str:
    """The paper's words: "free" and "restricted" (areas with flight restrictions)."""
    return "restricted" if is_zone(area) else ("free" if "free" in area.lower() or area == "all" else area)


def pair_keys(df, manifest) -> dict | None:
    """run_id -> the key that matches a strategy-A run with its strategy-B twin (every other parameter and the
    repetition: the runs that share their seed in a campaign with ``paired: [strategy]``); None when the
    campaign is not paired on the strategy."""
    if "strategy" not in (manifest.get("paired") or []) or df is None or UAV_COLUMN not in df.columns:
        return None
    keys = [k for k in manifest.get("param_keys", []) if k != "strategy" and k in df.columns] + ["rep"]
    totals = df[df[UAV_COLUMN] == TOTAL_ROW]
    return {rid: canonical_json([plain(v) for v in row])
            for rid, row in zip(totals["run_id"], totals[keys].itertuples(index=False))}
