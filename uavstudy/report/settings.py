"""What the runs actually flew with (their scenario.yaml and the settings their summaries recorded), and the
causes of a difference from the paper stated from those settings.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from master.campaign.spec import canonical_json

from ..names import TOTAL_ROW, UAV_COLUMN
from .tables import plain

__all__ = ["run_settings", "settings_summary", "causes"]

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
        scenario_file = Path(campaign_dir) / "runs" / str(rid) / "scenario.yaml"
        try:
            data = yaml.load(scenario_file.read_text(encoding="utf-8"), Loader=loader)
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
                d.update({c[len("settings."):]: plain(v) for c, v in zip(cols, row)
                          if v is not None and not (isinstance(v, float) and math.isnan(v))})
    return out


def settings_summary(settings: dict) -> tuple[dict, dict]:
    """(constant, varying): the settings every run shares (name -> value) and the ones that differ
    (name -> sorted distinct values)."""
    keys = sorted({k for s in settings.values() for k in s} - {"layout_seed", "layout_id"})
    const, vary = {}, {}
    for k in keys:
        distinct = {canonical_json(s.get(k)) for s in settings.values()}
        if len(distinct) == 1:
            const[k] = next(iter(settings.values())).get(k)
        else:
            vary[k] = sorted(json.loads(v) for v in distinct if v != "null")
    return const, vary


def causes(settings: dict) -> dict:
    """Why a claim can come out differently here, from the rule set the runs actually used."""
    const, vary = settings_summary(settings) if settings else ({}, {})

    def value_of(key, default="?"):
        if key in const:
            return f"{const[key]}"
        if key in vary:
            return " / ".join(str(v) for v in vary[key]) + " (varied)"
        return default

    zone_planning = value_of("zone_planning", None)
    planning = ("legs planned around the zones (20 m margin; a rule the paper does not have)"
                if zone_planning == "True" else
                "the paper's late detection only (no planning)" if zone_planning == "False" else
                f"zone_planning = {zone_planning}" if zone_planning else "zone rule not recorded")
    speed = next((k for k in ("cruise_speed", "speed.cruise", "cruise.speed", "speed") if k in const or k in vary),
                 None)
    rules = f" Rule set: {value_of('rules')}." if ("rules" in const or "rules" in vary) else ""
    return {
        "geometry": "The paper publishes no coordinates (its Fig. 4 is a map without scale): "
                    + ("every repetition of these runs flies its own random layout (24 targets, 4 restricted zones "
                       "drawn by the rules of docs/paper_config_format.md, uavstudy/layout.py)"
                       if value_of("layout", "") == "random" else
                       "our 24 targets, base and 4 restricted zones are one assumed layout "
                       "(ssp/scenarios/paper_area*.yaml, docs/paper_config_format.md)")
                    + f", area scale {value_of('area_scale', '1')}, take-off {value_of('takeoff', 'ring')}; every "
                    "absolute number (distances, battery, collision counts) depends on the geometry.",
        "energy": "Our battery is a physical model (uavsim.battery: rotor power from airspeed and climb, Li-ion pack) "
                  "instead of the paper's Ptolemy Energy actor, whose consumption law is not published"
                  + (f"; cruise speed {value_of(speed)} m/s" if speed else "") + "." + rules,
        "wind": f"The paper's wind model is not published; these runs drew wind episodes of "
                f"{value_of('wind_episode_s', value_of('wind.decision_interval'))} s with the given probability, "
                f"speeds {value_of('wind.intensities.weak')}/{value_of('wind.intensities.moderate')}/"
                f"{value_of('wind.intensities.strong')}"
                f" m/s from {value_of('wind.direction_deg')} degrees, "
                + ("one draw per UAV" if value_of("wind_shared", "") == "False" else
                   "one draw shared by the fleet" if value_of("wind_shared", "") == "True" else "shared or per UAV: ?")
                + ("; the wind pushes the UAV (displacement the controller does not cancel)"
                   if value_of("wind_effect", "") == "push" else
                   "; the wind is an air velocity the controller corrects" if value_of("wind_effect", "") == "drag"
                   else "") + ".",
        "collisions_count": "The paper does not say whether a UAV-UAV collision counts once or once per UAV; we count "
                            "removed UAVs (a UAV-UAV collision removes two).",
        "collisions_model": f"Collision detection is continuous (swept) over each step; zone detection of these runs: "
                            f"look-ahead {value_of('lookahead')} m, {planning}; zones of our assumed layout.",
        "success_def": "Success follows the paper: all assigned targets photographed, back at base with more than 5 % "
                       "battery; the 80 % return and 95 % forced-landing rules are applied by our strategy FMU.",
        "campaign": "This campaign is not the paper's 336-run grid.",
        "speed": f"Cruise speed of these runs: {value_of(speed) if speed else 'the strategy FMU default'} m/s. "
                 "The paper flies ArduCopter's default of its era (WPNAV_SPEED 500 cm/s = 5 m/s); the distance a "
                 "UAV covers before its 80 % return grows with the speed, so whether one UAV can fly the whole tour "
                 "depends on it.",
    }
