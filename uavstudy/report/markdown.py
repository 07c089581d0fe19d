"""The report's markdown: its sections in the order a reader meets them, each written from what
:mod:`.statistics` computed and :mod:`.findings` decided.

``cosim-master report`` calls :func:`uav_report` through the ``uav`` scenario kind; the markdown helpers are the
generic report's (``master.campaign.report``).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from master.campaign.report import campaign_facts, failures_md, md_table
from master.campaign.spec import design_roles

from . import cooperative
from .figures import draw_figures
from .findings import (COLLISION_RULE, NOT_SHOWN, REVERSED, YES, explanations, paper_comparison,
                       sensitivity_findings, table2, too_small, verdict_text)
from .paper_values import paper_consistency
from .settings import causes, run_settings, settings_summary
from .statistics import ab_effect, figure_data
from .tables import area_label, uav_frames
from .text import ci_text, n_text, num

__all__ = ["uav_report", "sensitivity_md"]

#: the captions of the figures, by figure key (:func:`.figures.draw_figures`)
CAPTIONS = {"fig5": "Fig. 5: successful UAV missions per fleet size and strategy",
            "fig6": "Fig. 6: mean remaining battery per area",
            "fig7": "Fig. 7: mean remaining battery per wind probability, by strategy and area; right: the "
                    "paired difference to the same configuration at 0 %",
            "fig8": "Fig. 8: total distance flown per wind probability; right: the paired difference per run",
            "fig9": "Fig. 9: collisions per impact point, per area (UAVs removed, the declared count), and the "
                    "wall / UAV-UAV ratio the verdict tests",
            "fig10": "Fig. 10: mean remaining battery per fleet size"}


def uav_report(manifest, df, out: Path) -> str | None:
    """The markdown of the report (figures written into ``out``); None when no UAV mission completed."""
    u, r = uav_frames(df)
    if u is None:
        return None
    design = manifest.get("design") or {}
    settings = run_settings(Path(out).parent, r["run_id"], df)
    lines = _header_md(manifest, df, u, r, settings)
    if cooperative.applies(r):
        lines += cooperative.cooperative_md(r, df, out, manifest["name"])
        if "A" not in set(r["strategy"]):   # a campaign of C against B: the paper's A-vs-B parts have nothing
            return "\n".join(lines + ["", _diagnostics(u, r), "", "## Failed runs", "", failures_md(df)])
    small = too_small(r)
    if design and not small:
        lines += sensitivity_md(u, r, design)
    if design:
        baseline_runs = r[r["config"] == next((c for c in dict.fromkeys(r["config"])
                                               if "baseline" in design_roles(json.loads(c), design)),
                                              r["config"].iloc[0])]
        lines += ["## The baseline configuration", "",
                  "The comparison, figures and tables below are the baseline configuration's (the paper's rules) "
                  "on this campaign's reduced grid: totals are scaled to the paper's 420 missions per strategy, "
                  "but the mix of fleet sizes and wind levels differs from the paper's grid.", ""]
        u = u[u["run_id"].isin(set(baseline_runs["run_id"]))]
        r = baseline_runs
    fd = figure_data(u, r)
    files = draw_figures(fd, out, r)
    if small:
        lines += ["## Too small to score against the paper", "", f"This campaign has {small}", ""]
    else:
        comparison = paper_comparison(u, r)
        lines += _comparison_md(fd, comparison)
        lines += _differences_md(comparison, causes(settings))
    lines += ["", _diagnostics(u, r), ""]
    lines += _figures_md(fd, files)
    lines += _figure_tables_md(fd, r)
    if not small:
        lines += _table2_md(fd, table2(u, r), r)
    lines += _replays_md(Path(out), r)
    lines += ["## Failed runs", "", failures_md(df)]
    return "\n".join(lines)


def _replays_md(out: Path, r) -> list[str]:
    """A link to each run's replay.html where its folder keeps one (``keep: all``; uavstudy.replay)."""
    kept = [row for row in r.itertuples() if (out.parent / "runs" / row.run_id / "replay.html").is_file()]
    rows = [[row.run_id, row.strategy, row.n_uavs, row.area, f"{row.wind:g}", row.rep,
             f"[replay.html](../runs/{row.run_id}/replay.html)"] for row in kept]
    return ["## Replays", "", md_table(["run", "strategy", "UAVs", "area", "wind", "rep", "replay"], rows), ""] \
        if rows else []


def _header_md(manifest, df, u, r, settings: dict) -> list[str]:
    """The title, the campaign's facts, the settings the runs flew with and how the statistics are done."""
    lines = [f"# Campaign report: {manifest['name']}", ""]
    lines += [f"- {x}" for x in campaign_facts(manifest, df)]
    lines += [f"- Analysed: {n_text(r, u)}."]
    const, vary = settings_summary(settings) if settings else ({}, {})
    if const:
        lines += ["- Settings every run flew with (its scenario.yaml and the settings its summary recorded): "
                  + ", ".join(f"`{k}` = {v}" for k, v in const.items()) + "."]
    if vary:
        lines += ["- Settings that differ between runs: "
                  + ", ".join(f"`{k}` in {v}" for k, v in vary.items()) + "."]
    lines += ["", "**Statistics.** The layout is the unit of replication: every repetition flies its own random "
                  "area, shared by all its runs (both strategies, every fleet size, area and wind), so the runs of "
                  "one layout are not independent and the layouts are. Every number is computed per layout first "
                  "(a level, a total, or the mean of the layout's paired differences: B - A of the same cell, "
                  "restricted - free, wind w - 0 %, fleet n2 - n1 of the same configuration; a within-configuration "
                  "slope), then averaged over the layouts with the 95 % t interval (df = layouts - 1) and the "
                  "matching two-sided t-test; a ratio of totals carries Fieller's interval, which inverts the same "
                  "t-test. Interval and p-value come from one method: p < 0.05 exactly when the interval excludes "
                  "the null. Totals are given per three layouts (the paper's 336-run grid) or per the paper's 420 "
                  "missions per strategy.", "",
              "**Verdict rule** (fixed before the data, docs/paper_reproduction.md): a statement the paper makes is "
              "*yes* when our interval excludes the null with the paper's sign, *reversed* when it excludes it "
              "with the opposite sign, otherwise *not shown*; a finding of several statements is yes when all "
              "are, reversed when all are, *partly* (or *mixed*) otherwise. Magnitude separately: *within* when "
              "the paper's number lies in our interval widened by the stated tolerance, else *outside*.", "",
              f"**Collision count.** {COLLISION_RULE}", ""]
    return lines


def _comparison_md(fd: dict, comparison: list[dict]) -> list[str]:
    """Our numbers next to the paper's, the statements tested, the quotes, and the paper's contradictions."""
    lines = ["## Our numbers next to the paper's", "", f"{fd['n']}.", ""]
    rows = [[i + 1, c["key"], c["paper"], c["ours"], verdict_text(c)] for i, c in enumerate(comparison)]
    lines += [md_table(["#", "finding", "paper", "ours", "verdict"], rows), ""]
    lines += ["Tolerances of the magnitudes (fixed before the data): 2 battery points; 10 % of a distance or a "
              "collision count; 0 for the paper's zero success counts; 1 around the wall/UAV ratio of 3.", "",
              "### The statements tested", ""]
    for i, c in enumerate(comparison):
        f = c["finding"]
        bits = [p.text() for p in f.parts] + [m.text() for m in f.magnitudes]
        if f.other_reading:
            bits.append(f.other_reading)
        if f.note:
            bits.append(f.note)
        if bits:
            lines += [f"- **{i + 1}. {c['key']}**: " + "; ".join(bits) + "."]
    lines += ["", "Quotes (paper, section V):", ""]
    lines += [f"- *{c['key']}*: {c['quote']}" for c in comparison]
    lines += ["", "## The paper's numbers that cannot all hold together", ""]
    lines += [f"- {x}" for x in paper_consistency()]
    return lines


def _differences_md(comparison: list[dict], why_text: dict) -> list[str]:
    """Each finding not reproduced, with its facts.  The settings named are hypotheses: this campaign varies
    none of them; the sensitivity campaign measures them (its report, docs/paper_reproduction.md)."""
    lines = ["", "## Findings not reproduced", ""]
    differing = [c for c in comparison if not c["finding"].reproduced]
    if not differing:
        lines += ["Every published finding is reproduced.", ""]
    first_said: dict = {}          # a fact shared by several findings is written once
    for c in differing:
        fact = c["fact"]
        if fact in first_said:
            fact = f"(Facts: as under {first_said[fact]}.)"
        elif fact:
            first_said[fact] = c["key"]
        lines += [f"- **{c['key']}** ({verdict_text(c)}) — paper: {c['paper']}; ours: {c['ours']}. {fact}"]
    lines += ["", "What explains each of them is measured by the sensitivity campaign "
                  "(`ssp/campaigns/sensitivity.yaml`: which factor moves or flips each statement, with its interval) "
                  "and summarised in docs/paper_reproduction.md. The settings these runs flew with, from which the "
                  "factors varied there were chosen:", ""]
    lines += [f"- {why_text[w]}" for w in ("geometry", "energy", "wind", "collisions_model", "speed")
              if w in why_text]
    return lines


def _figures_md(fd: dict, files: dict) -> list[str]:
    lines = ["## Figures", ""]
    for k, path in files.items():
        lines += [f"![{CAPTIONS[k]}]({path.name})", "", f"*{CAPTIONS[k]}. {fd['n']}.*", ""]
    return lines


def _figure_tables_md(fd: dict, r) -> list[str]:
    """The numbers of Figs. 5-10 as tables."""
    lines = ["### Successes per fleet size (Fig. 5), per three layouts [95 % interval over layouts]", ""]
    rows = []
    for n in fd["fleets"]:
        row = [n]
        for s in fd["strategies"]:
            k, m, ci = fd["fig5"][(s, n)]
            row.append(f"{ci.fmt(1)} of {num(m * 3 / max(1, fd['layouts']), 0)} ({k}/{m} over {fd['layouts']} "
                       f"layouts)")
        if {"A", "B"} <= set(fd["strategies"]):
            row.append(ci_text(ab_effect(r[r["n_uavs"] == n], "successes")))
        rows.append(row)
    lines += [md_table(["UAVs", *[f"Strategy {s}" for s in fd["strategies"]], "B - A successes per run"], rows), ""]
    lines += ["### Remaining battery (Figs. 6, 7, 10), mean % over UAV missions [95 % interval over layouts]", ""]
    rows = [[s, area_label(a), fd["fig6"][(s, a)].fmt(1)] for s in fd["strategies"] for a in fd["areas"]]
    lines += [md_table(["strategy", "area", "remaining battery"], rows), ""]
    rows = [[s, area_label(a)] + [fd["fig7"][(s, a, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]
            for a in fd["areas"]]
    lines += [md_table(["strategy", "area", *[f"wind probability {num(w * 100, 1)} %" for w in fd["winds"]]],
                       rows), ""]
    if fd["fig7b"]:
        rows = [[s, area_label(a)] + [ci_text(fd["fig7b"][(s, a, w)], 1, show_n=False) for w in fd["winds"] if w > 0]
                for s in fd["strategies"] for a in fd["areas"]]
        lines += [f"Paired difference to 0 % wind (same configuration and layout), %-points, over {fd['layouts']} "
                  "layouts:", "",
                  md_table(["strategy", "area", *[f"{num(w * 100, 1)} %" for w in fd["winds"] if w > 0]], rows), ""]
    rows = [[s] + [fd["fig10"][(s, n)].fmt(1) for n in fd["fleets"]] for s in fd["strategies"]]
    lines += [md_table(["strategy", *[f"{n} UAV" for n in fd["fleets"]]], rows), ""]
    lines += ["### Total distance (Fig. 8), km per three layouts [95 % interval over layouts]", ""]
    rows = [[s] + [fd["fig8"][(s, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]]
    lines += [md_table(["strategy", *[f"wind probability {num(w * 100, 1)} %" for w in fd["winds"]]], rows), ""]
    lines += ["### Collisions per impact point (Fig. 9), UAVs removed per three layouts [95 % interval over "
              "layouts]", ""]
    rows = [[s, area_label(a), fd["fig9"][(s, a, "uav")].fmt(1), fd["fig9"][(s, a, "zone")].fmt(1)]
            for s in fd["strategies"] for a in fd["areas"]]
    lines += [md_table(["strategy", "area", "UAV-UAV", "restricted area (wall)"], rows), ""]
    rows = [[s, fd["fig9_ratio"][s].fmt(2, "×")] for s in fd["strategies"]]
    lines += ["Wall / UAV-UAV ratio (UAVs removed, both areas; Fieller interval over layouts):", "",
              md_table(["strategy", "wall / UAV-UAV"], rows), ""]
    return lines


def _table2_md(fd: dict, t2: list[dict], r) -> list[str]:
    """Table II with the comparison over layouts behind each verdict."""
    lines = ["## Table II - which strategy is better", "", f"{fd['n']}.", ""]
    rows = [[x["metric"], x["A"], x["B"], ci_text(x["effect"], 3), f"{x['b_ahead']} of {x['n_layouts']}",
             x["better"], "B"] for x in t2]
    lines += [md_table(["metric", "Strategy A", "Strategy B", "B - A per run [95 % interval], t-test p, layouts",
                        "layouts where B is better", "better (ours)", "paper"], rows), ""]
    lines += ["Totals are per three layouts (the paper's grid), battery the mean over missions. \"better\" follows "
              "the verdict rule: B (or A) when the interval over layouts excludes 0 on its side, otherwise \"not "
              "shown\". More successes, photos and remaining energy are better; less distance and fewer "
              "collisions are better (the paper's reading). \"with wind\" rows use the runs with a wind "
              "probability above 0.", ""]
    return lines


def sensitivity_md(u, r, design: dict) -> list[str]:
    """The sensitivity section of a campaign with a ``design:``: per configuration the verdict of each finding,
    and per statement the configurations that move it (difference to the baseline over the same layouts,
    interval excluding 0) or flip its verdict -- or that no tested factor does."""
    sf = sensitivity_findings(u, r, design)
    labels = sf["labels"]
    baseline = ", ".join(f"{k} = {v}" for k, v in design["baseline"].items())
    base_runs = r[r["config"] == sf["baseline"]]
    lines = ["## Sensitivity: which assumptions move or flip which finding", "",
             f"One factor at a time around the baseline ({baseline})"
             + (f", plus the factorial {' x '.join(f'{k} {v}' for k, v in design['factorial'].items())}"
                if design.get("factorial") else "")
             + f". Each configuration runs the same grid on the same layouts ({n_text(base_runs)} per "
               "configuration). Verdicts follow the rule above. A configuration *moves* a statement when the "
               "per-layout difference to the baseline (same layouts) has a 95 % t interval excluding 0; it "
               "*flips* it when the verdict changes.", ""]
    keys = [f.key for f in sf["findings"][sf["baseline"]] if f.parts]
    short = {YES: "yes", REVERSED: "**reversed**", NOT_SHOWN: "·"}
    rows = []
    for c in sf["configs"]:
        by_key = {f.key: f for f in sf["findings"][c]}
        rows.append([labels[c], *[short.get(by_key[k].direction, by_key[k].direction) if k in by_key else "n/a"
                                  for k in keys]])
    lines += ["Direction verdict of each finding per configuration (· = not shown):", "",
              md_table(["configuration", *keys], rows), ""]
    lines += ["### What explains each statement not reproduced at the baseline", "",
              "A statement is reproduced when its direction is *yes* (magnitude: *within*). Listed: the "
              "configurations in which it is reproduced, else those that move it significantly towards the paper "
              "(change to the baseline on the same layouts, 95 % interval), else that no tested factor explains "
              "it.", ""]
    for (fkey, label, kind), (how, items) in explanations(sf).items():
        stmt = sf["statements"][sf["baseline"]][(fkey, label, kind)]
        unit, digits = getattr(stmt, "unit", ""), stmt.digits
        head = f"- **{fkey} — {label}** ({kind}; baseline {stmt.verdict or 'n/a'}): "
        if items:
            head += how + " " + "; ".join(f"*{labels[m['config']]}* ({m['verdict'] or 'n/a'}: "
                                          f"{ci_text(m['stat'], digits, unit, show_n=False)}; change "
                                          f"{ci_text(m['delta'], digits, unit, show_n=False)})" for m in items) + "."
        else:
            head += "no tested factor explains it."
        lines += [head]
    lines += ["", "### Per statement: the baseline, and what moves or flips it", ""]
    for (fkey, label, kind), stmt in sf["statements"][sf["baseline"]].items():
        unit, digits = getattr(stmt, "unit", ""), stmt.digits
        head = (f"- **{fkey} — {label}** ({kind}): baseline {ci_text(stmt.stat, digits, unit)}"
                + (f" vs paper {num(stmt.paper, digits)}{unit}" if kind == "magnitude" else "")
                + f" → {stmt.verdict or 'n/a'}.")
        moved = sf["moves"][(fkey, label, kind)]
        if moved:
            items = [f"*{labels[m['config']]}*: {ci_text(m['stat'], digits, unit)} ({m['verdict'] or 'n/a'}), "
                     f"change {ci_text(m['delta'], digits, unit)}"
                     + (" — flips it" if m["flipped"] else "") for m in moved]
            head += " Moved or flipped by: " + "; ".join(items) + "."
        else:
            head += " No tested factor moves or flips it."
        lines += [head]
    lines += [""]
    return lines


def _diagnostics(u, r) -> str:
    """Facts from our runs that explain the comparison (outcome mix, when collisions happen)."""
    import pandas as pd
    lines = ["Mission outcomes of our UAV missions (per strategy and area):", ""]
    outcomes = u.groupby(["strategy", "area", "outcome"]).size().unstack(fill_value=0)
    header = ["strategy", "area", *[str(c) for c in outcomes.columns]]
    rows = [[s, a, *[int(v) for v in outcomes.loc[(s, a)].to_numpy()]] for s, a in outcomes.index]
    lines += [md_table(header, rows), ""]
    removal_times = pd.to_numeric(u["removed_time"], errors="coerce") if "removed_time" in u.columns else None
    if removal_times is not None and removal_times.notna().any():
        parts = []
        for s in sorted(set(u["strategy"])):
            x = removal_times[(u["strategy"] == s) & removal_times.notna()]
            if len(x):
                parts.append(f"{s}: {len(x)} removals, median at t = {x.median():.0f} s, "
                             f"{(x <= 120).mean() * 100:.0f} % within the first 2 min")
        lines += ["When collisions happen (simulation time of the removal): " + "; ".join(parts) + ".", ""]
    if "outcome" in u.columns:
        timeouts = (u["outcome"] == "timeout").sum()
        if timeouts:
            lines += [f"**{timeouts} UAV mission(s) were still flying at the stop time** (outcome timeout): the "
                      "campaign's stop time is too short for them.", ""]
    return "\n".join(lines)
