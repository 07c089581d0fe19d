"""The verdicts: which strategy is better on each metric of Table II, whether each of the paper's claims holds
in our runs (by value where the paper gives a number, by direction otherwise), and, for a campaign with a
``design:``, which configurations flip which finding.

The numbers come from :mod:`.statistics`; the rules that turn them into a verdict (the sign that counts as
"better", significance at alpha = 0.05, the tolerances of :mod:`.paper_values`) are here.
"""
from __future__ import annotations

import json
import math

from master.campaign import blocked as bl
from master.campaign.spec import canonical_json, design_roles

from ..names import UAV_COLLISION, ZONE_COLLISION
from .paper_values import PAPER, PAPER_VALUES
from .statistics import (NO_CI, ab_effect, area_effect, fleet_slope, level_ci, per_layout, total_ci, wind_effect,
                         wind_slope)
from .tables import area_label, is_zone
from .text import effect_text, ratio_text

__all__ = ["TABLE2", "table2", "paper_comparison", "verdict_text", "flip_kind", "sensitivity_findings"]

#: the rows of Table II: key, label, per-run column, which direction is better, with-wind runs only, and the
#: aggregate shown (count of successes | sum over runs | mean over missions)
TABLE2 = [
    ("success", "Success per number of UAVs", "successes", "higher", False, "count"),
    ("photos", "Number of photos", "photos", "higher", False, "sum"),
    ("photos_wind", "Number of photos with wind", "photos", "higher", True, "sum"),
    ("energy", "Remaining energy", "battery", "higher", False, "mean"),
    ("energy_wind", "Remaining energy with wind", "battery", "higher", True, "mean"),
    ("distance", "Travelled distance", "distance_km", "lower", False, "sum"),
    ("distance_wind", "Travelled distance with wind", "distance_km", "lower", True, "sum"),
    ("collisions", "Number of collisions", "collisions", "lower", False, "sum"),
]


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


def _facts(u, r, fd) -> dict:
    """Data-driven sentences that explain a comparison, keyed by claim."""
    f: dict = {}
    removed = u["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
    if len(u):
        kept = u[~removed]["remaining_battery_pct"]
        removal_times = u[removed]["removed_time"].astype(float)
        battery_at_removal = u[removed]["remaining_battery_pct"].astype(float)
        f["battery_total"] = (f"{removed.mean() * 100:.0f} % of our UAV missions end in a collision (median at "
                              f"t = {removal_times.median():.0f} s, {battery_at_removal.mean():.1f} % battery left "
                              f"on average); over the other "
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
    successes = fd["fig5"]
    fleets = fd["fleets"]
    maxes = ", ".join(str(successes.get(("A", n), (0, 0))[1]) for n in fleets)
    add("max_success", maxes, None, () if maxes == "42, 84, 126, 168" else ("campaign",),
        value=bl.Agreement(maxes == "42, 84, 126, 168", "the UAV missions per fleet size of the grid"))

    def successes_of(s, n):
        return successes.get((s, n), (0, 0, NO_CI))
    if 1 in fleets:
        (ka, ma, ca), (kb, mb, cb) = successes_of("A", 1), successes_of("B", 1)
        v = both(bl.agrees_by_value(0.0, ca, 0.0), bl.agrees_by_value(0.0, cb, 0.0))
        add("success_1", f"{ka}/{ma} (A), {kb}/{mb} (B)", None, ("speed", "geometry", "energy", "success_def"),
            value=v)
    if 2 in fleets:
        (ka, ma, ca), (kb, mb, _) = successes_of("A", 2), successes_of("B", 2)
        v = bl.agrees_by_value(0.0, ca, 0.0)
        add("success_2", f"{ka}/{ma} (A), {kb}/{mb} (B)", kb > 0 and ka == 0,
            ("speed", "geometry", "energy", "success_def"),
            value=bl.Agreement(v.agrees and kb > 0, v.text) if v.agrees is not None else None)
    success_row = next(x for x in t2 if x["key"] == "success")
    add("success_dir",
        f"{success_row['A']} (A) vs {success_row['B']} (B); B - A per run {effect_text(success_row['effect'])}",
        None if success_row["lead"] == "tie" else success_row["lead"] == "B",
        ("geometry", "collisions_model", "speed"), sig=success_row["effect"].significant)
    battery_means = {s: level_ci(r[r["strategy"] == s], "battery", True, 0.0, 100.0) for s in ("A", "B")}
    energy_row = next(x for x in t2 if x["key"] == "energy")
    v = both(bl.agrees_by_value(PAPER_VALUES["battery_A"][0], battery_means["A"], PAPER_VALUES["battery_A"][1]),
             bl.agrees_by_value(PAPER_VALUES["battery_B"][0], battery_means["B"], PAPER_VALUES["battery_B"][1]))
    add("battery_total", f"{battery_means['A'].fmt(2, ' %')} (A), {battery_means['B'].fmt(2, ' %')} (B); "
                         f"B - A {effect_text(energy_row['effect'])}",
        battery_means["B"].estimate > battery_means["A"].estimate,
        ("energy", "speed", "geometry", "collisions_model"),
        "mean over UAV missions; tolerance ±2 points around our interval", sig=energy_row["effect"].significant,
        value=v)
    parts, agree, sig = [], True, True
    for a in fd["areas"]:
        e = ab_effect(r[r["area"] == a], "battery")
        parts.append(f"{area_label(a)}: A {fd['fig6'].get(('A', a), NO_CI).fmt(1)} vs B "
                     f"{fd['fig6'].get(('B', a), NO_CI).fmt(1)}; "
                     f"B - A {effect_text(e, 1)}")
        agree &= e.estimate < 0
        sig &= e.significant
    add("battery_area", "; ".join(parts), agree, ("collisions_model", "geometry", "energy"), sig=sig)
    slope = wind_slope(r, "battery")
    top = max(fd["winds"])
    e_top = wind_effect(r, "battery", top) if top > 0 else None
    add("battery_wind", "within-configuration slope (%-points per %-point of wind probability) "
                        f"{effect_text(slope, 3)}"
                        + (f"; {top * 100:g} % vs 0 %: {effect_text(e_top, 2)}" if e_top else ""),
        None if not math.isfinite(slope.estimate) else slope.estimate < 0, ("wind",),
        "direction only (the paper gives no value)", sig=slope.significant)
    zones = [a for a in fd["areas"] if is_zone(a)]
    free = [a for a in fd["areas"] if not is_zone(a)]
    if zones and free:
        e = area_effect(r, "battery", zones)
        add("battery_zones", f"restricted - free per run {effect_text(e, 1)}", e.estimate > 0,
            ("collisions_model", "geometry"), "same configuration and repetition in both areas", sig=e.significant)
    distance_row = next(x for x in t2 if x["key"] == "distance")
    km_a, km_b = r[r["strategy"] == "A"]["distance_km"].sum(), r[r["strategy"] == "B"]["distance_km"].sum()
    km_ci_a = total_ci(r[r["strategy"] == "A"], "distance_km")
    km_ci_b = total_ci(r[r["strategy"] == "B"], "distance_km")
    v = both(bl.agrees_by_value(PAPER_VALUES["distance_A"][0], km_ci_a, PAPER_VALUES["distance_A"][1]),
             bl.agrees_by_value(PAPER_VALUES["distance_B"][0], km_ci_b, PAPER_VALUES["distance_B"][1]))
    add("distance_total", f"{km_a:.1f} km (A), {km_b:.1f} km (B); "
                          f"B - A per run {effect_text(distance_row['effect'], 3, ' km')}",
        km_b < km_a, ("speed", "geometry", "collisions_model"), "sum over every UAV of every run; tolerance ±10 %",
        sig=distance_row["effect"].significant, value=v)
    if zones and free:
        e = area_effect(r, "distance_km", zones)
        add("distance_zones", f"restricted - free per run {effect_text(e, 3, ' km')}", e.estimate < 0,
            ("collisions_model", "geometry"), sig=e.significant)
    slope = wind_slope(r, "distance_km")
    add("distance_wind", "within-configuration slope (km per run per %-point of wind probability) "
                         f"{effect_text(slope, 4)}",
        None if not math.isfinite(slope.estimate) else slope.estimate > 0, ("wind",),
        "direction only", sig=slope.significant)
    collisions_row = next(x for x in t2 if x["key"] == "collisions")

    def counts(col):
        runs_a, runs_b = r[r["strategy"] == "A"], r[r["strategy"] == "B"]
        v = both(bl.agrees_by_value(PAPER_VALUES["collisions_A"][0], total_ci(runs_a, col),
                                    PAPER_VALUES["collisions_A"][1]),
                 bl.agrees_by_value(PAPER_VALUES["collisions_B"][0], total_ci(runs_b, col),
                                    PAPER_VALUES["collisions_B"][1]))
        return int(runs_a[col].sum()), int(runs_b[col].sum()), v
    removed_a, removed_b, v_uav = counts("collisions")
    events_a, events_b, v_events = counts("collision_events")
    v = v_events if v_events.agrees else v_uav
    add("collisions", f"{removed_a} (A), {removed_b} (B) UAVs removed; counting a UAV-UAV collision once: "
                      f"{events_a} (A), {events_b} (B); "
                      f"B - A UAVs removed per run {effect_text(collisions_row['effect'])}", removed_a > removed_b,
        ("collisions_model", "collisions_count", "geometry"),
        f"tolerance ±10 %; UAVs removed {'agree' if v_uav.agrees else 'do not agree'}, collisions counted once per "
        f"event {'agree' if v_events.agrees else 'do not agree'}", sig=collisions_row["effect"].significant,
        value=bl.Agreement(v.agrees, f"UAVs removed: {v_uav.text}; events: {v_events.text}"))
    parts, agree_uav, agree_events = [], True, True
    ratio, ratio_tolerance = PAPER_VALUES["wall_ratio"][:2]
    for s in ("A", "B"):
        sub = r[r["strategy"] == s]
        uavs_removed, zone_removed = int(sub["uav_collided"].sum()), int(sub["zone_collided"].sum())
        uav_events = int(sub["uav_events"].sum())
        parts.append(f"{s}: {zone_removed} zone vs {uavs_removed} UAVs removed by each other "
                     f"({ratio_text(zone_removed, uavs_removed)}), vs {uav_events} UAV-UAV "
                     f"collisions ({ratio_text(zone_removed, uav_events)})")
        agree_uav &= uavs_removed > 0 and abs(zone_removed / uavs_removed - ratio) <= ratio_tolerance
        agree_events &= uav_events > 0 and abs(zone_removed / uav_events - ratio) <= ratio_tolerance
    add("wall_ratio", "; ".join(parts), None, ("collisions_model", "geometry", "collisions_count", "wind"),
        value=bl.Agreement(agree_uav or agree_events,
                           "ratio within 3 ± 1 in both strategies: counting removed UAVs "
                           f"{'yes' if agree_uav else 'no'}, counting collisions {'yes' if agree_events else 'no'}"))
    parts, agree, sig = [], True, True
    for s in ("A", "B"):
        e = fleet_slope(r[r["strategy"] == s], "battery")
        means = ", ".join(f"{n}: {fd['fig10'][(s, n)].estimate:.1f}" for n in fd["fleets"] if (s, n) in fd["fig10"])
        parts.append(f"{s}: within-configuration slope (%-points per UAV) {effect_text(e, 2)} (means {means})")
        agree = agree and math.isfinite(e.estimate) and e.estimate > 0
        sig = sig and e.significant
    add("battery_fleet", "; ".join(parts), agree, ("speed", "energy", "geometry", "collisions_model"), sig=sig)
    b_better = sum(1 for x in t2 if x["better"] == "B")
    a_better = sum(1 for x in t2 if x["better"] == "A")
    b_ahead = sum(1 for x in t2 if x["lead"] == "B")
    add("table2", f"B significantly better on {b_better}, A on {a_better}, no significant difference on "
                  f"{len(t2) - b_better - a_better} (B ahead, significant or not, on {b_ahead} of {len(t2)})",
        b_better == len(t2),
        ("geometry", "collisions_model", "speed"))
    return rows


def verdict_text(c: dict) -> str:
    """The "agrees" cell of a comparison row: yes / **no**, by value or by direction, and whether our test is
    significant."""
    if c["agree"] is None:
        return "n/a"
    text = "yes" if c["agree"] else "**no**"
    text += " (value)" if c.get("value") is not None and c["value"].agrees is not None else " (direction)"
    if c["sig"] is False:
        text += ", not significant"
    return text


def _finding_tests():
    """The paper's findings a sensitivity campaign checks per configuration: key -> (label, test on the runs of
    one configuration returning (holds: bool | None, evidence text, the statistic's estimate or None))."""
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
        return _holds(e, +1), f"B - A successes per run {effect_text(e)}", e.estimate

    def wind_battery(r):
        e = wind_slope(r, "battery")
        return _holds(e, -1), f"slope {effect_text(e, 3)} %/%-pt", e.estimate

    def wind_distance(r):
        e = wind_slope(r, "distance_km")
        return _holds(e, +1), f"slope {effect_text(e, 4)} km/%-pt", e.estimate

    def b_shorter(r):
        e = ab_effect(r, "distance_km")
        return _holds(e, -1), f"B - A km per run {effect_text(e, 3)}", e.estimate

    def wall_ratio(r):
        uav_events, zone_removed = int(r["uav_events"].sum()), int(r["zone_collided"].sum())
        return ((uav_events > 0 and 2.0 <= zone_removed / uav_events <= 4.0),
                f"zone {zone_removed} vs UAV-UAV {uav_events} ({ratio_text(zone_removed, uav_events)})", None)

    def b_fewer_collisions(r):
        e = ab_effect(r, "collisions")
        return _holds(e, -1), f"B - A collisions per run {effect_text(e)}", e.estimate

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
    """A configuration named by what differs from the baseline ("lookahead = 10, wind_effect = drag")."""
    values = json.loads(config)
    diff = {k: v for k, v in values.items() if k in baseline and canonical_json(baseline[k]) != canonical_json(v)}
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
    baseline_config = next((c for c in configs if "baseline" in design_roles(json.loads(c), design)), None)
    flips = {}
    for k in tests:
        holds_at_baseline = table[baseline_config][k][0] if baseline_config else None
        flips[k] = [c for c in configs if c != baseline_config and table[c][k][0] is not None
                    and holds_at_baseline is not None and table[c][k][0] != holds_at_baseline]
    return {"tests": {k: label for k, (label, _) in tests.items()}, "table": table, "baseline": baseline_config,
            "flips": flips, "labels": {c: _config_label(c, base) for c in configs},
            "roles": {c: design_roles(json.loads(c), design) for c in configs}}
