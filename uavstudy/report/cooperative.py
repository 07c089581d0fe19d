"""The report of a campaign of strategy C against B (docs/cooperative.md): does the UAV-to-UAV channel reduce
collisions and raise successes, per rule set, and at which channel range and loss does the benefit disappear?

The statistics are the paper report's (:mod:`.statistics`): the **layout is the unit**.  Every C run is compared
with the B run of the same layout, rule set, fleet size, area and wind (its *twin*: B has no channel, so the
channel axes do not enter the pairing, and a campaign may fly B once per twin group while C flies every channel
setting); the C - B differences of a layout are averaged (over the runs of the subset: a rule set, a range
level, ...), then the layouts' values give the mean with its t interval (df = layouts - 1) and t-test
(:func:`master.campaign.stats.layout_t`).  Verdicts follow the report's rule (:func:`.findings.direction_verdict`):
*yes* when the interval excludes 0 on the side the question asks for, *reversed* on the other side, otherwise
*not shown*.  The benefit "disappears" at the first channel level, from the best channel towards the worst
(longest range first; lowest loss first), whose verdict is not *yes*.

Beside the monitor's per-UAV success (a UAV's own assigned targets, which counts a UAV that handed a target to a
better-placed one as incomplete), the section judges the **fleet**: a run's fleet mission is complete when the
fleet photographed every target of the mission, whoever did (``fleet_complete``, 1 or 0 per run).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from master.campaign import stats as st
from master.campaign.report import md_table

from .findings import NOT_SHOWN, REVERSED, YES, direction_verdict
from .text import ci_text, n_text

__all__ = ["METRICS", "applies", "with_run_values", "c_minus_b", "effect", "effects_by", "verdict", "disappears_at",
           "cooperative_md", "draw_channel_figure"]

#: (column, what it is, the sign that is a benefit of C: +1 higher is better, -1 lower, None no side)
METRICS = [("successes", "successful UAV missions per run", +1),
           ("fleet_complete", "runs whose fleet photographed every target (fraction)", +1),
           ("uav_collided", "UAVs removed by UAV-UAV collisions per run", -1),
           ("zone_collided", "UAVs removed by zone incursions per run", -1),
           ("battery", "remaining battery, mean over the run's UAVs (%)", +1),
           ("distance_km", "distance flown per run (km)", None),
           ("targets_per_wh", "targets visited per Wh (fleet)", +1)]
#: the two questions of the issue; the channel tables and the figure answer them
CLAIMS = ["successes", "uav_collided"]
CHANNEL_AXES = {"range": ("comm.range", "channel range (m)", -1), "loss": ("comm.loss", "message loss", +1)}


def applies(r) -> bool:
    """A campaign with strategies B and C (with or without A) gets the C-against-B section."""
    return r is not None and {"B", "C"} <= set(r["strategy"].astype(str))


def with_run_values(r, df):
    """``r`` with ``targets_per_wh`` (the fleet's targets visited over its energy, from the run's total row),
    ``fleet_complete`` (1 when the fleet visited every target of the mission, else 0; from the total row) and the
    channel levels ``range``/``loss`` as numbers (NaN where a run has none: B)."""
    import pandas as pd
    r = r.copy()
    total = None
    if df is not None and "targets_visited" in df.columns:
        from ..names import TOTAL_ROW, UAV_COLUMN
        total = df[df[UAV_COLUMN] == TOTAL_ROW].set_index("run_id")
    if total is not None and "energy_used_Wh_sum" in total.columns:
        visited = pd.to_numeric(total.loc[r["run_id"], "targets_visited"], errors="coerce").to_numpy(float)
        wh = pd.to_numeric(total.loc[r["run_id"], "energy_used_Wh_sum"], errors="coerce").to_numpy(float)
        with np.errstate(divide="ignore", invalid="ignore"):
            r["targets_per_wh"] = np.where(wh > 0, visited / wh, np.nan)
    elif "targets_per_wh" not in r.columns:
        r["targets_per_wh"] = np.nan
    if total is not None and "targets_total" in total.columns:
        visited = pd.to_numeric(total.loc[r["run_id"], "targets_visited"], errors="coerce").to_numpy(float)
        of = pd.to_numeric(total.loc[r["run_id"], "targets_total"], errors="coerce").to_numpy(float)
        with np.errstate(invalid="ignore"):
            r["fleet_complete"] = np.where(np.isfinite(visited) & np.isfinite(of), (visited >= of) * 1.0, np.nan)
    elif "fleet_complete" not in r.columns:
        r["fleet_complete"] = np.nan
    for name, (col, _, _) in CHANNEL_AXES.items():
        if name not in r.columns:
            r[name] = pd.to_numeric(r[col], errors="coerce") if col in r.columns else np.nan
    return r


def _twin_key(r):
    """Layout, configuration without its channel parameters (rule set, ...), fleet, area and wind: what a C run
    and its B twin share."""
    def strip(c):
        return json.dumps({k: v for k, v in json.loads(c).items() if not k.startswith("comm.")}, sort_keys=True)
    return (r["layout"].astype(str) + "|" + r["config"].map(strip) + "|" + r["n_uavs"].astype(str) + "|"
            + r["area"].astype(str) + "|" + r["wind"].map(lambda w: f"{float(w):g}"))


def c_minus_b(r, value: str):
    """One row per C run that has a B twin: layout, the C run's columns and ``diff`` = value(C) - value(B twin)
    (the mean of the twins if B flew more than once, e.g. once per channel setting, where they are identical)."""
    key = _twin_key(r)
    b = r[r["strategy"] == "B"].assign(_k=key[r["strategy"] == "B"])
    b_value = b.groupby("_k")[value].mean()
    c = r[r["strategy"] == "C"].assign(_k=key[r["strategy"] == "C"])
    c = c[c["_k"].isin(b_value.index)]
    c = c.assign(diff=c[value].to_numpy(float) - b_value.loc[c["_k"]].to_numpy(float))
    return c[np.isfinite(c["diff"].to_numpy(float))]


def effect(d) -> st.LayoutCI:
    """Mean C - B of the paired rows ``d`` (from :func:`c_minus_b`): per layout, then over layouts."""
    return st.layout_t({k: float(g["diff"].mean()) for k, g in d.groupby("layout", sort=True)})


def effects_by(r, value: str, by: str | None = None) -> dict:
    """level -> C - B over the C runs at that level of ``by`` (None: all runs, key "all")."""
    d = c_minus_b(r, value)
    if by is None:
        return {"all": effect(d)}
    return {lv: effect(g) for lv, g in sorted(d.groupby(by), key=lambda kv: kv[0])}


def verdict(ci: st.LayoutCI, sign) -> str:
    """yes / reversed / not shown for a metric with a benefit side; for one without, the side of a
    significant difference (C higher, C lower) or not shown."""
    if sign is not None:
        return direction_verdict(ci, sign)
    v = direction_verdict(ci, +1)
    return {YES: "C higher", REVERSED: "C lower"}.get(v, NOT_SHOWN)


def disappears_at(effects: dict, sign: int, worse: int):
    """The first level, going from the best channel towards the worst (``worse`` = +1: larger levels are worse,
    as loss; -1: smaller are worse, as range), whose verdict is not yes; None when every level shows it."""
    for level in sorted(effects, key=lambda x: worse * x):
        if direction_verdict(effects[level], sign) != YES:
            return level
    return None


def _disappear_text(effects: dict, sign: int, worse: int, unit: str) -> str:
    if not effects:
        return "n/a"
    level = disappears_at(effects, sign, worse)
    best = sorted(effects, key=lambda x: worse * x)[0]
    if level is None:
        return "not within the levels flown (shown at every level)"
    if level == best:
        return f"not shown even at the best level ({level:g}{unit})"
    return f"at {level:g}{unit} ({direction_verdict(effects[level], sign)})"


def cooperative_md(r, df, out: Path, name: str) -> list[str]:
    """The "Strategy C against B" section (and its figure, written into ``out``)."""
    r = with_run_values(r, df)
    rc = r[r["strategy"].isin(["B", "C"])]
    lines = ["## Strategy C against B", "",
             f"{n_text(rc)}. Every C run is compared with the B run of the same layout, rule set, fleet size, area "
             "and wind (B has no channel, so the channel parameters are not part of the pairing); the C - B "
             "differences are averaged per layout, then over the layouts: mean [95 % t interval, df = layouts - "
             "1], t-test p, layouts. Verdict: *yes* when the interval excludes 0 on the side of a benefit of C "
             "(fewer collisions, more successes, more battery, more targets per Wh), *reversed* on the other "
             "side, otherwise *not shown*; distance has no benefit side (C higher / C lower / not shown).", ""]
    rules = sorted(set(rc["rules"].astype(str))) if "rules" in rc.columns else []
    groups = [("all", rc)] + [(f"{x} rules", rc[rc["rules"].astype(str) == x]) for x in rules]
    rows = []
    for col, label, sign in METRICS:
        if not np.isfinite(rc[col].to_numpy(float)).any():
            continue
        for gname, g in groups:
            ci = effects_by(g, col)["all"]
            rows.append([label, gname, ci_text(ci, 3), verdict(ci, sign)])
    lines += ["### C - B per run, overall and per rule set", "",
              md_table(["quantity", "runs", "C - B", "verdict"], rows), ""]
    lines += _success_levels(groups)
    if "n_uavs" in rc.columns:
        rows = []
        for n, g in rc.groupby("n_uavs"):
            cis = [effects_by(g, col)["all"] for col in CLAIMS]
            rows.append([int(n)] + [f"{ci_text(ci, 3)} ({verdict(ci, s)})"
                                    for ci, s in zip(cis, [m[2] for m in METRICS if m[0] in CLAIMS])])
        lines += ["### Per fleet size", "", md_table(["UAVs", *[m[1] for m in METRICS if m[0] in CLAIMS]], rows), ""]
    channel = {}
    for axis, (col, label, worse) in CHANNEL_AXES.items():
        if not np.isfinite(rc[rc["strategy"] == "C"][axis].to_numpy(float)).any():
            continue
        lines += [f"### C - B per {label}", "",
                  f"Each level pools the other channel settings, both rule sets, every fleet size and wind"
                  f"{' (the shortest ranges too, where C hears little)' if axis == 'loss' else ''}."
                  f" The benefit disappears at the first level, from the best channel towards the worst, whose "
                  f"verdict is not *yes*.", ""]
        rows, stops = [], []
        per_metric = {}
        for mcol, mlabel, sign in METRICS:
            if mcol not in CLAIMS:
                continue
            for gname, g in groups:
                eff = effects_by(g, mcol, axis)
                per_metric[(mcol, gname)] = eff
                stops.append([mlabel, gname, _disappear_text(eff, sign, worse, " m" if axis == "range" else "")])
        levels = sorted({lv for e in per_metric.values() for lv in e}, key=lambda x: worse * x)
        for lv in levels:
            row = [f"{lv:g}"]
            for mcol in CLAIMS:
                sign = next(m[2] for m in METRICS if m[0] == mcol)
                for gname, _ in groups:
                    ci = per_metric[(mcol, gname)].get(lv)
                    row.append(f"{ci_text(ci, 2, show_n=False)} ({verdict(ci, sign)})" if ci else "n/a")
            rows.append(row)
        header = [label] + [f"{'successes' if m == 'successes' else 'UAV-UAV removals'}, {g}"
                            for m in CLAIMS for g, _ in groups]
        lines += [md_table(header, rows), "", md_table(["quantity", "runs", "benefit disappears"], stops), ""]
        channel[axis] = per_metric
    if channel:
        path = draw_channel_figure(channel, [g for g, _ in groups], Path(out), name, int(rc["layout"].nunique()))
        lines += [f"![C - B as the channel degrades]({path.name})", "",
                  "Figure: C - B per run (successful UAV missions, UAVs removed by UAV-UAV collisions) per channel "
                  "range and per message loss, mean over layouts with its 95 % t interval, for all runs and per "
                  "rule set.", ""]
    return lines


def _success_levels(groups) -> list[str]:
    """Per-UAV and fleet-level success of B and C side by side (means over the runs of each strategy): the
    monitor's per-UAV success counts a target handed to a better-placed UAV against the UAV that dropped it, the
    fleet's completion does not."""
    rows = []
    for gname, g in groups:
        b, c = g[g["strategy"] == "B"], g[g["strategy"] == "C"]
        if not len(b) or not len(c) or not np.isfinite(g["fleet_complete"].to_numpy(float)).any():
            continue
        per_uav = [f"{x['successes'].mean():.2f} of {x['n_uavs'].mean():.2f}" if "n_uavs" in x.columns
                   else f"{x['successes'].mean():.2f}" for x in (b, c)]
        rows.append([gname, *per_uav, *(f"{x['fleet_complete'].mean():.3f}" for x in (b, c)), f"{len(b)} / {len(c)}"])
    if not rows:
        return []
    return ["### Per-UAV and fleet-level success", "",
            "Means over the runs of each strategy (descriptive; the C - B rows above are the paired comparison). "
            "Per-UAV success is the monitor's: a UAV's own assigned targets photographed and back home, so a UAV "
            "that dropped a target to a better-placed UAV counts as incomplete; the fleet's mission is complete "
            "when every target was photographed, by whichever UAV.", "",
            md_table(["runs", "successful UAVs per run, B", "successful UAVs per run, C", "fleet complete, B",
                      "fleet complete, C", "runs B / C"], rows), ""]


def draw_channel_figure(channel: dict, groups: list, out: Path, name: str, layouts: int) -> Path:
    """C's benefit as the channel degrades: rows successes / UAV-UAV removals, columns range / loss; each point
    a level's C - B with its interval bar, one series per group (all runs, each rule set)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    axes_names = [a for a in ("range", "loss") if a in channel]
    fig = Figure(figsize=(5.0 * len(axes_names), 7.0), dpi=90)
    FigureCanvasAgg(fig)
    colors = ["black", "tab:red", "tab:green", "tab:blue"]
    titles = {"successes": "successful UAV missions, C - B per run",
              "uav_collided": "UAVs removed by UAV-UAV collisions, C - B per run"}
    for i, mcol in enumerate(CLAIMS):
        for j, axis in enumerate(axes_names):
            ax = fig.add_subplot(len(CLAIMS), len(axes_names), i * len(axes_names) + j + 1)
            for k, g in enumerate(groups):
                eff = channel[axis].get((mcol, g), {})
                levels = sorted(eff, key=lambda x: CHANNEL_AXES[axis][2] * x)   # best channel on the left
                if not levels:
                    continue
                xs = np.arange(len(levels)) + (k - (len(groups) - 1) / 2) * 0.12
                est = np.array([eff[lv].estimate for lv in levels])
                lo = np.array([eff[lv].low for lv in levels])
                hi = np.array([eff[lv].high for lv in levels])
                ok = np.isfinite(lo)
                yerr = np.vstack([np.where(ok, est - lo, 0.0), np.where(ok, hi - est, 0.0)])
                ax.errorbar(xs, est, yerr=yerr, fmt="o-", color=colors[k % len(colors)], capsize=3, ms=4,
                            lw=1, label=g)
                ax.set_xticks(np.arange(len(levels)))
                ax.set_xticklabels([f"{lv:g}" for lv in levels])
            ax.axhline(0.0, color="gray", lw=0.8, ls="--")
            ax.set_xlabel(CHANNEL_AXES[axis][1] + " (worse to the right)")
            ax.set_title(titles[mcol], fontsize=9)
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle(f"{name}: C's benefit over B as the channel degrades (mean over {layouts} layouts, 95 % t "
                 "interval)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    path = Path(out) / "fig_channel_benefit.png"
    fig.savefig(path)
    return path

