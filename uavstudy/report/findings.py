"""The verdicts: whether each of the paper's findings holds in our runs, which strategy is better on each row of
Table II, and, for a campaign with a ``design:``, which configurations move or flip each finding.

**The verdict rule** (fixed before the data; docs/paper_reproduction.md states the same rule):

* *direction*: each tested statistic has the sign the paper claims.  Its 95 % interval over layouts and the
  matching t-test (:mod:`.statistics`) decide: significant (the interval excludes the null, p < 0.05) with the
  paper's sign = **yes**; significant with the opposite sign = **reversed**; otherwise **not shown** (we can
  neither confirm nor reject it).  A finding made of several statements (both areas, both strategies, every
  fleet step, the 8 rows of Table II) is *yes* when every part is yes, *reversed* when every part is reversed,
  *mixed* when some parts are yes and some reversed, *partly* when some are yes and none reversed, *partly
  reversed* when some are reversed and none yes, else *not shown*.
* *magnitude*, separately, where the paper gives a number: **within** when the paper's number lies in our 95 %
  interval widened by the tolerance of :data:`.paper_values.PAPER_VALUES` on both sides, else **outside**.

**The collision count** is declared from the paper's text, not from which reading fits (see
:data:`COLLISION_RULE`): a collision is a UAV's collision, so a UAV-UAV collision counts twice (both UAVs are
removed).  The other reading (once per UAV-UAV collision) is shown beside it and never used in a verdict.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

from master.campaign import stats as st
from master.campaign.spec import canonical_json, design_roles

from ..names import UAV_COLLISION, ZONE_COLLISION
from .paper_values import PAPER, PAPER_MISSIONS, PAPER_REPETITIONS, PAPER_VALUES
from .statistics import (ab_effect, area_effect, fleet_step, fleet_slope, level_ci, n_layouts, per_mission_total,
                         ratio_ci, wind_effect, wind_slope)
from .tables import area_label, is_zone
from .text import ci_text, num

__all__ = ["TABLE2", "table2", "paper_comparison", "verdict_text", "sensitivity_findings", "Part", "Magnitude",
           "direction_verdict", "combine", "COLLISION_RULE", "MIN_LAYOUTS", "too_small", "finding_rows", "explanations",
           "YES", "REVERSED", "NOT_SHOWN"]

YES, REVERSED, NOT_SHOWN = "yes", "reversed", "not shown"
WITHIN, OUTSIDE = "within", "outside"
#: fewer independent layouts than this and a campaign is too small to be scored against the paper (a t interval
#: over 2 layouts has df = 1: t(0.975, 1) = 12.7)
MIN_LAYOUTS = 3

#: the collision-counting rule, declared from the paper's text (section III-A and V) before looking at the data
COLLISION_RULE = (
    "We count **one collision per UAV removed** (a UAV-UAV collision counts twice). The paper defines the "
    "collision from each UAV's side: \"each UAV calculates its distance to all others present in the simulation "
    "and checks for the intersection of areas\", \"If a collision is detected, the colliding UAV is removed from "
    "the simulation\", and for the count \"it was defined that a collision occurs regardless of the type of "
    "impact point, a UAV, or a restricted area\": the impact point is what a UAV hit, so each of the two UAVs of a "
    "UAV-UAV collision has a collision whose impact point is a UAV. The paper's other counts are per UAV mission "
    "too (\"42, 84, 126, 168\" successes). The other reading, one per UAV-UAV collision, is shown beside it for "
    "information; no verdict uses it.")


@dataclass
class Part:
    """One tested statement of a finding: a statistic over layouts and the sign the paper claims for it
    (relative to the statistic's null: 0 for a difference or slope, 1 for a ratio)."""
    label: str
    stat: st.LayoutCI
    sign: int
    digits: int = 2
    unit: str = ""

    @property
    def verdict(self) -> str:
        return direction_verdict(self.stat, self.sign)

    def text(self) -> str:
        return f"{self.label} {ci_text(self.stat, self.digits, self.unit)} ({self.verdict})"


@dataclass
class Magnitude:
    """The paper's number against our interval widened by the tolerance."""
    label: str
    paper: float
    tolerance: float
    stat: st.LayoutCI
    digits: int = 1
    unit: str = ""

    @property
    def verdict(self) -> str | None:
        s = self.stat
        if s.n < 2 or not math.isfinite(s.low):
            return None
        return WITHIN if s.low - self.tolerance <= self.paper <= s.high + self.tolerance else OUTSIDE

    def text(self) -> str:
        v = self.verdict
        return (f"{self.label} {self.stat.fmt(self.digits, self.unit)} vs paper {num(self.paper, self.digits)}"
                f"{self.unit} ± {num(self.tolerance, self.digits)} ({v or 'n/a'})")


def direction_verdict(stat: st.LayoutCI, sign: int) -> str:
    """yes / reversed / not shown, from the interval (and its t-test) alone."""
    null = stat.null or 0.0
    if not stat.significant or not math.isfinite(stat.estimate) or stat.estimate == null:
        return NOT_SHOWN
    return YES if (stat.estimate - null) * sign > 0 else REVERSED


def combine(verdicts: list[str]) -> str:
    """The verdict of a finding made of several parts (module docstring)."""
    if not verdicts:
        return NOT_SHOWN
    yes, rev = verdicts.count(YES), verdicts.count(REVERSED)
    if yes == len(verdicts):
        return YES
    if rev == len(verdicts):
        return REVERSED
    if yes and rev:
        return "mixed"
    if yes:
        return "partly"
    if rev:
        return "partly reversed"
    return NOT_SHOWN


@dataclass
class Finding:
    key: str
    ours: str
    parts: list = field(default_factory=list)         # Part: the direction statements
    magnitudes: list = field(default_factory=list)    # Magnitude: the paper's numbers
    design: bool | None = None                        # runs / max_success: our grid is the paper's
    other_reading: str = ""                           # shown, never used in the verdict
    note: str = ""

    @property
    def direction(self) -> str | None:
        return combine([p.verdict for p in self.parts]) if self.parts else None

    @property
    def magnitude(self) -> str | None:
        vs = [m.verdict for m in self.magnitudes]
        if not vs:
            return None
        if OUTSIDE in vs:
            return OUTSIDE
        return WITHIN if all(v == WITHIN for v in vs) else "n/a"

    @property
    def reproduced(self) -> bool:
        """Reproduced: every tested direction yes and every magnitude within (a design row: its grid)."""
        if self.design is not None:
            return self.design
        return (self.direction in (None, YES) and self.magnitude in (None, WITHIN)
                and (self.direction is not None or self.magnitude is not None))


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


def table2(u, r) -> list[dict]:
    """Table II: for each metric A's and B's level (per three layouts, or the mean over missions) and B - A per
    run over layouts, which decides "better" by the verdict rule."""
    rows = []
    for key, label, col, better, wind_only, shown in TABLE2:
        data = r[r["wind"] > 0] if wind_only else r
        a, b = data[data["strategy"] == "A"], data[data["strategy"] == "B"]
        row = {"key": key, "metric": label, "n_A": len(a), "n_B": len(b)}
        by_missions = shown == "mean"
        if by_missions:
            row.update(A=level_ci(a, col, True).fmt(2, " %"), B=level_ci(b, col, True).fmt(2, " %"))
        else:
            unit = " km" if col == "distance_km" else ""
            row.update(A=per_mission_total(a, col, _missions(a)).fmt(1, unit),
                       B=per_mission_total(b, col, _missions(b)).fmt(1, unit))
        e = ab_effect(data, col, by_missions)
        sign = 1 if better == "higher" else -1
        part = Part(label, e, sign, 3)
        row.update(effect=e, part=part, p=e.p, n_layouts=e.n,
                   b_ahead=sum(1 for v in e.per_layout.values() if v * sign > 0))
        row["better"] = {YES: "B", REVERSED: "A"}.get(part.verdict, "not shown")
        row["sense"] = better
        rows.append(row)
    return rows


def _missions(r) -> int:
    """UAV missions of these runs per three layouts (the paper's grid size for this subset)."""
    n = n_layouts(r)
    return int(round(r["n_uavs"].sum() * PAPER_REPETITIONS / n)) if n else 0


def too_small(r) -> str | None:
    """Why these runs cannot be scored against the paper (None when they can)."""
    n = n_layouts(r)
    if n < MIN_LAYOUTS:
        return (f"{n} independent replicate{'s' if n != 1 else ''} (random layouts, or repetitions of a fixed "
                f"area): at least {MIN_LAYOUTS} are needed for an interval over them, and the paper campaign uses "
                f"24 (docs/paper_reproduction.md, \"How many layouts\"). This campaign is too small to be scored "
                f"against the paper; its numbers are shown without intervals.")
    if set(r["strategy"]) < {"A", "B"}:
        return "the campaign does not fly both strategies A and B: it cannot be scored against the paper."
    return None


def finding_rows(u, r) -> list[Finding]:
    """The paper's 16 findings measured on the runs ``r`` (and their missions ``u``): one Finding each, with
    the statistics its verdict rests on.  Works on any subset with both strategies (a configuration of a
    sensitivity campaign: fleet sizes or wind levels it lacks leave those parts out)."""
    out: list[Finding] = []
    ra, rb = r[r["strategy"] == "A"], r[r["strategy"] == "B"]
    fleets = sorted(set(int(x) for x in r["n_uavs"]))
    winds = sorted(set(float(x) for x in r["wind"]))
    areas = sorted(set(r["area"]), key=lambda a: (is_zone(a), a))
    zones = [a for a in areas if is_zone(a)]
    n_lay = n_layouts(r)
    per_layout_runs = len(r) / n_lay if n_lay else 0
    # -- the grid
    out.append(Finding("runs", f"{len(r)} runs = {n_lay} layouts x {num(per_layout_runs, 0)} runs; per 3 layouts "
                               f"{num(per_layout_runs * PAPER_REPETITIONS, 0)}",
                       design=per_layout_runs * PAPER_REPETITIONS == 336))
    maxes = ", ".join(str(_missions(ra[ra["n_uavs"] == n])) for n in fleets)
    out.append(Finding("max_success", f"{maxes} per 3 layouts", design=maxes == "42, 84, 126, 168"))

    def successes(sub, n):
        s = sub[sub["n_uavs"] == n]
        return s, int(s["successes"].sum()), int(s["n_uavs"].sum())
    # -- Fig. 5
    if 1 in fleets:
        (sa, ka, ma), (sb, kb, mb) = successes(ra, 1), successes(rb, 1)
        out.append(Finding("success_1", f"{ka}/{ma} (A), {kb}/{mb} (B) over {n_lay} layouts",
                           magnitudes=[Magnitude("A per 3 layouts", 0.0, 0.0, per_mission_total(sa, "successes",
                                                                                                _missions(sa))),
                                       Magnitude("B per 3 layouts", 0.0, 0.0, per_mission_total(sb, "successes",
                                                                                                _missions(sb)))]))
    if 2 in fleets:
        (sa, ka, ma), (sb, kb, mb) = successes(ra, 2), successes(rb, 2)
        out.append(Finding("success_2", f"{ka}/{ma} (A), {kb}/{mb} (B) over {n_lay} layouts",
                           parts=[Part("B - A successes per 2-UAV run", ab_effect(r[r["n_uavs"] == 2], "successes"),
                                       +1)],
                           magnitudes=[Magnitude("A per 3 layouts", 0.0, 0.0,
                                                 per_mission_total(sa, "successes", _missions(sa)))]))
    k_a, k_b = int(ra["successes"].sum()), int(rb["successes"].sum())
    out.append(Finding("success_dir", f"{k_a}/{int(ra['n_uavs'].sum())} (A) vs {k_b}/{int(rb['n_uavs'].sum())} (B); "
                                      f"B - A per run {ci_text(ab_effect(r, 'successes'))}",
                       parts=[Part("B - A successes per run", ab_effect(r, "successes"), +1)]))
    # -- battery (Figs. 6, 7, 10)
    lev_a, lev_b = level_ci(ra, "battery", True, 0.0, 100.0), level_ci(rb, "battery", True, 0.0, 100.0)
    out.append(Finding("battery_total", f"{lev_a.fmt(1, ' %')} (A), {lev_b.fmt(1, ' %')} (B); B - A "
                                        f"{ci_text(ab_effect(r, 'battery', True), 1, ' %-pt')}",
                       parts=[Part("B - A (mission means)", ab_effect(r, "battery", True), +1, 1, " %-pt")],
                       magnitudes=[Magnitude("A", *PAPER_VALUES["battery_A"][:2], lev_a, 1, " %"),
                                   Magnitude("B", *PAPER_VALUES["battery_B"][:2], lev_b, 1, " %")],
                       note="mean over UAV missions"))
    out.append(Finding("battery_area", "; ".join(
        f"{area_label(a)}: A {level_ci(ra[ra['area'] == a], 'battery', True, 0.0, 100.0).fmt(1)} vs B "
        f"{level_ci(rb[rb['area'] == a], 'battery', True, 0.0, 100.0).fmt(1)}" for a in areas),
        parts=[Part(f"{area_label(a)}: B - A", ab_effect(r[r["area"] == a], "battery", True), -1, 1, " %-pt")
               for a in areas]))
    if len(winds) > 1:
        top = max(winds)
        out.append(Finding("battery_wind", "within-configuration slope per %-pt of wind probability "
                                           f"{ci_text(wind_slope(r, 'battery'), 3, ' %-pt')}; "
                                           f"{num(top * 100, 1)} % vs 0 %: "
                                           f"{ci_text(wind_effect(r, 'battery', top), 2, ' %-pt')}",
                           parts=[Part("slope per %-pt of wind probability", wind_slope(r, "battery"), -1, 3,
                                       " %-pt")]))
    if zones and len(areas) > 1:
        out.append(Finding("battery_zones", "restricted - free per run "
                           + ci_text(area_effect(r, "battery", zones), 1, " %-pt"),
                           parts=[Part("restricted - free", area_effect(r, "battery", zones), +1, 1, " %-pt")]))
    # -- distance (Fig. 8)
    km_a, km_b = (per_mission_total(ra, "distance_km"), per_mission_total(rb, "distance_km"))
    out.append(Finding("distance_total", f"{km_a.fmt(0, ' km')} (A), {km_b.fmt(0, ' km')} (B) per 420 missions "
                                         f"(ours / paper: A {_ratio(km_a, 270.0)}, B {_ratio(km_b, 240.0)})",
                       parts=[Part("B - A per run", ab_effect(r, "distance_km"), -1, 3, " km")],
                       magnitudes=[Magnitude("A", *PAPER_VALUES["distance_A"][:2], km_a, 0, " km"),
                                   Magnitude("B", *PAPER_VALUES["distance_B"][:2], km_b, 0, " km")],
                       note="sum over every UAV mission, per the paper's 420 missions per strategy"))
    if zones and len(areas) > 1:
        out.append(Finding("distance_zones", "restricted - free per run "
                           + ci_text(area_effect(r, "distance_km", zones), 3, " km"),
                           parts=[Part("restricted - free", area_effect(r, "distance_km", zones), -1, 3, " km")]))
    if len(winds) > 1:
        out.append(Finding("distance_wind", "within-configuration slope per %-pt of wind probability "
                           + ci_text(wind_slope(r, "distance_km"), 4, " km"),
                           parts=[Part("slope per %-pt of wind probability", wind_slope(r, "distance_km"), +1, 4,
                                       " km")]))
    # -- collisions (Fig. 9), counted by COLLISION_RULE
    col_a, col_b = per_mission_total(ra, "collisions"), per_mission_total(rb, "collisions")
    ev_a, ev_b = per_mission_total(ra, "collision_events"), per_mission_total(rb, "collision_events")
    out.append(Finding("collisions", f"UAVs removed per 420 missions: {col_a.fmt(0)} (A), {col_b.fmt(0)} (B); "
                                     f"B - A per run {ci_text(ab_effect(r, 'collisions'))}",
                       parts=[Part("B - A UAVs removed per run", ab_effect(r, "collisions"), -1)],
                       magnitudes=[Magnitude("A", *PAPER_VALUES["collisions_A"][:2], col_a, 0),
                                   Magnitude("B", *PAPER_VALUES["collisions_B"][:2], col_b, 0)],
                       other_reading=f"counting a UAV-UAV collision once (not used): {ev_a.fmt(0)} (A), "
                                     f"{ev_b.fmt(0)} (B)"))
    ratio, tol = PAPER_VALUES["wall_ratio"][:2]
    rat = {s: ratio_ci(sub, "zone_collided", "uav_collided") for s, sub in (("A", ra), ("B", rb))}
    once = {s: ratio_ci(sub, "zone_collided", "uav_events") for s, sub in (("A", ra), ("B", rb))}
    parts = [Part(f"{s}: wall / UAV-UAV", rat[s], +1) for s in ("A", "B")]
    if len(winds) > 1:
        parts.append(Part("wind raises wall collisions: slope per %-pt", wind_slope(r, "zone_collided"), +1, 4))
    out.append(Finding("wall_ratio", "; ".join(
        f"{s}: {int(sub['zone_collided'].sum())} wall vs {int(sub['uav_collided'].sum())} UAV-UAV (UAVs removed), "
        f"{rat[s].fmt(2, '×')}" for s, sub in (("A", ra), ("B", rb))), parts=parts,
        magnitudes=[Magnitude(f"{s}: ratio", ratio, tol, rat[s], 2, "×") for s in ("A", "B")],
        other_reading="counting a UAV-UAV collision once (not used): " + ", ".join(
            f"{s} {once[s].fmt(2, '×')}" for s in ("A", "B"))))
    # -- Fig. 10: every step up in fleet size raises the battery, except A's 1 -> 2 (the paper's exception)
    steps = []
    for s in ("A", "B"):
        sub = r[r["strategy"] == s]
        for n1, n2 in zip(fleets, fleets[1:]):
            sign = -1 if (s == "A" and n1 == 1) else +1
            steps.append(Part(f"{s} {n1}->{n2} UAVs", fleet_step(sub, "battery", n1, n2), sign, 1, " %-pt"))
    def fleet_mean(s, n):
        return level_ci(r[(r["strategy"] == s) & (r["n_uavs"] == n)], "battery", True, 0.0, 100.0).fmt(1)
    means = "; ".join(f"{s}: " + ", ".join(f"{n}: {fleet_mean(s, n)}" for n in fleets) for s in ("A", "B"))
    out.append(Finding("battery_fleet", means + "; slopes per UAV: "
                       + ", ".join(f"{s} {ci_text(fleet_slope(r[r['strategy'] == s], 'battery'), 1)}"
                                   for s in ("A", "B")),
                       parts=steps,
                       note="tested: each step to the next fleet size, expected up except A's 1 -> 2 UAVs (down: "
                            "the paper's exception); the slopes are shown, not tested"))
    t2 = table2(u, r)
    out.append(Finding("table2", f"B better on {sum(x['better'] == 'B' for x in t2)}, A on "
                                 f"{sum(x['better'] == 'A' for x in t2)}, not shown on "
                                 f"{sum(x['better'] == 'not shown' for x in t2)} of {len(t2)}",
                       parts=[x["part"] for x in t2]))
    return out


def _ratio(ci: st.LayoutCI, paper: float) -> str:
    return f"{ci.estimate / paper:.1f}×" if math.isfinite(ci.estimate) else "n/a"


def paper_comparison(u, r) -> list[dict]:
    """One row per published claim: the paper's value and quote, ours, the Finding (parts, magnitudes,
    verdicts) and the facts that explain it."""
    facts = _facts(u, r)
    rows = []
    for f in finding_rows(u, r):
        paper, quote = PAPER[f.key]
        rows.append({"key": f.key, "paper": paper, "quote": quote, "ours": f.ours, "finding": f,
                     "fact": facts.get(f.key, "")})
    return rows


def verdict_text(c: dict) -> str:
    """The verdict cell of a comparison row."""
    f: Finding = c["finding"]
    if f.design is not None:
        return "same grid" if f.design else "**other grid**"
    out = []
    if f.direction is not None:
        out.append(f"direction: {f.direction if f.direction == YES else '**' + f.direction + '**'}")
    if f.magnitude is not None:
        out.append(f"magnitude: {f.magnitude if f.magnitude == WITHIN else '**' + f.magnitude + '**'}")
    return "; ".join(out) or "n/a"


def _facts(u, r) -> dict:
    """Data-driven sentences that explain a comparison, keyed by claim."""
    import pandas as pd
    f: dict = {}
    if not len(u):
        return f
    t = pd.to_numeric(u["removed_time"], errors="coerce") if "removed_time" in u.columns else None
    parts = []
    for s in sorted(set(u["strategy"])):
        sub = u[u["strategy"] == s]
        bits = []
        for kind, label in ((UAV_COLLISION, "UAV-UAV"), (ZONE_COLLISION, "wall")):
            k = sub[sub["outcome"] == kind]
            if len(k):
                tk = t[k.index] if t is not None else None
                bits.append(f"{len(k)} by {label} collisions (median t = {num(tk.median(), 0)} s, "
                            f"{num(k['remaining_battery_pct'].mean(), 1)} % battery left)")
        kept = sub[~sub["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])]
        bits.append(f"{len(kept)} not removed ({num(kept['remaining_battery_pct'].mean(), 1)} % left)")
        parts.append(f"{s}: " + ", ".join(bits))
    f["battery_total"] = "UAV missions removed: " + "; ".join(parts) + "."
    f["battery_area"] = f["battery_zones"] = f["battery_fleet"] = f["battery_total"]
    f["collisions"] = f["wall_ratio"] = f["battery_total"]
    if "distance_m" in u.columns:
        bits = []
        for s in sorted(set(u["strategy"])):
            sub = u[u["strategy"] == s]
            rm = sub["outcome"].isin([UAV_COLLISION, ZONE_COLLISION])
            bits.append(f"{s}: {num(rm.mean() * 100, 0)} % of missions removed by a collision, the others flew "
                        f"{num(sub[~rm]['distance_m'].astype(float).mean() / 1000, 2)} km on average")
        f["distance_total"] = "Per UAV mission: " + "; ".join(bits) + "."
    one = u[(u["n_uavs"] == 1) & (u["outcome"] == "success")]
    if len(one):
        f["success_1"] = (f"{len(one)} single-UAV missions succeeded with "
                          f"{num(one['remaining_battery_pct'].mean(), 1)} % battery left on average.")
    two = u[u["n_uavs"] == 2]
    if len(two):
        oc = two.groupby("strategy")["outcome"].value_counts().unstack(fill_value=0)
        f["success_2"] = "Outcomes with 2 UAVs: " + "; ".join(
            f"{s}: " + ", ".join(f"{k} {int(v)}" for k, v in oc.loc[s].items() if v) for s in oc.index) + "."
    return f


# ----------------------------------------------------------------------------------- sensitivity
def _config_label(config: str, baseline: dict) -> str:
    """A configuration named by what differs from the baseline ("lookahead = 10, wind_effect = drag")."""
    values = json.loads(config)
    diff = {k: v for k, v in values.items() if k in baseline and canonical_json(baseline[k]) != canonical_json(v)}
    return "baseline" if not diff else ", ".join(f"{k} = {v}" for k, v in diff.items())


def _statements(findings: list[Finding]) -> dict:
    """(finding key, part label, kind) -> Part or Magnitude, over the findings of one configuration."""
    out = {}
    for f in findings:
        for p in f.parts:
            out[(f.key, p.label, "direction")] = p
        for m in f.magnitudes:
            out[(f.key, m.label, "magnitude")] = m
    return out


def _towards_paper(stmt, delta: st.LayoutCI) -> bool:
    """Does a significant change move the statement towards the paper (its sign for a direction, its number for
    a magnitude)?"""
    if not delta.significant:
        return False
    if isinstance(stmt, Part):
        return delta.estimate * stmt.sign > 0
    return delta.estimate * (stmt.paper - stmt.stat.estimate) > 0


def explanations(sf: dict) -> dict:
    """For each statement not reproduced at the baseline (direction not yes, magnitude not within): the
    configurations that reproduce it (verdict yes / within there), else those that move it significantly towards
    the paper; an empty list means that no tested factor explains it."""
    out = {}
    for key, stmt in sf["statements"][sf["baseline"]].items():
        goal = YES if key[2] == "direction" else WITHIN
        if stmt.verdict == goal:
            continue
        moved = sf["moves"][key]
        reproduce = [m for m in moved if m["verdict"] == goal]
        out[key] = ("reproduced by", reproduce) if reproduce else \
            ("moved towards the paper by", [m for m in moved if m["towards_paper"]])
    return out


def sensitivity_findings(u, r, design: dict) -> dict:
    """For a campaign with a design: the findings in every configuration (baseline, each one-at-a-time value,
    each factorial point) on the same layouts, and per statement (a finding's part or magnitude) the
    configurations that move it -- the per-layout difference to the baseline (same layouts) has an interval
    excluding 0 -- or flip its verdict."""
    base = design["baseline"]
    configs = list(dict.fromkeys(r["config"]))
    per_config = {c: finding_rows(u[u["run_id"].isin(set(r[r["config"] == c]["run_id"]))], r[r["config"] == c])
                  for c in configs}
    baseline_config = next((c for c in configs if "baseline" in design_roles(json.loads(c), design)), configs[0])
    statements = {c: _statements(fs) for c, fs in per_config.items()}
    moves: dict = {}
    for key, stmt in statements[baseline_config].items():
        rows = []
        for c in configs:
            if c == baseline_config or key not in statements[c]:
                continue
            other = statements[c][key]
            delta = st.layout_difference(stmt.stat, other.stat)
            flipped = other.verdict != stmt.verdict
            if delta.significant or flipped:
                rows.append({"config": c, "delta": delta, "verdict": other.verdict, "stat": other.stat,
                             "flipped": flipped, "moved": delta.significant,
                             "towards_paper": _towards_paper(stmt, delta)})
        moves[key] = rows
    return {"configs": configs, "baseline": baseline_config, "findings": per_config, "statements": statements,
            "moves": moves, "labels": {c: _config_label(c, base) for c in configs},
            "roles": {c: design_roles(json.loads(c), design) for c in configs}}
