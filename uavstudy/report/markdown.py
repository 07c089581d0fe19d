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

from .figures import draw_figures
from .findings import flip_kind, paper_comparison, sensitivity_findings, table2, verdict_text
from .paper_values import paper_consistency
from .settings import causes, run_settings, settings_summary
from .statistics import ab_effect, figure_data
from .tables import area_label, uav_frames
from .text import effect_text, n_text, p_text

__all__ = ["uav_report", "sensitivity_md"]

#: the captions of the figures, by figure key (:func:`.figures.draw_figures`)
CAPTIONS = {"fig5": "Fig. 5: successful UAV missions per fleet size and strategy",
            "fig6": "Fig. 6: mean remaining battery per area",
            "fig7": "Fig. 7: mean remaining battery per wind probability, by strategy and area; right: the "
                    "paired difference to the same configuration at 0 %",
            "fig8": "Fig. 8: total distance flown per wind probability; right: the paired difference per run",
            "fig9": "Fig. 9: collisions per impact point, per area",
            "fig10": "Fig. 10: mean remaining battery per fleet size"}


def uav_report(manifest, df, out: Path) -> str | None:
    """The markdown of the report (figures written into ``out``); None when no UAV mission completed."""
    u, r = uav_frames(df)
    if u is None:
        return None
    design = manifest.get("design") or {}
    settings = run_settings(Path(out).parent, r["run_id"], df)
    lines = _header_md(manifest, df, u, r, settings)
    if design:
        lines += sensitivity_md(r, design)
        baseline_runs = r[r["config"] == next((c for c in dict.fromkeys(r["config"])
                                               if "baseline" in design_roles(json.loads(c), design)),
                                              r["config"].iloc[0])]
        lines += ["The figures and tables below are the baseline configuration's.", ""]
        u = u[u["run_id"].isin(set(baseline_runs["run_id"]))]
        r = baseline_runs
    fd = figure_data(u, r)
    files = draw_figures(fd, out, r)
    t2 = table2(u, r)
    comparison = paper_comparison(u, r, fd, t2)
    lines += _comparison_md(fd, comparison)
    lines += _differences_md(comparison, causes(settings))
    lines += ["", _diagnostics(u, r), ""]
    lines += _figures_md(fd, files)
    lines += _figure_tables_md(fd, r)
    lines += _table2_md(fd, t2, r)
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
    paired = "strategy" in (manifest.get("paired") or [])
    lines += ["", "Statistics: the run is the unit (its UAVs share wind and layout). A vs B is compared inside "
                  "blocks (same configuration and repetition" + (", same seed: same wind and layout" if paired else
                                                                "; the campaign is not paired, so the seeds differ")
              + "): the mean B - A difference per run with a t interval stratified by configuration, the block "
              "bootstrap interval and the sign-flip permutation p-value. Levels pooled over configurations "
              "carry stratified intervals (within-configuration variance only). Wind effects are differences "
              "inside a configuration and repetition against its 0 % run. Every figure and table states n "
              "(runs, UAV missions, configurations, layouts).", ""]
    return lines


def _comparison_md(fd: dict, comparison: list[dict]) -> list[str]:
    """Our numbers next to the paper's, the quotes, and the paper's numbers that contradict each other."""
    lines = ["## Our numbers next to the paper's", "", f"{fd['n']}.", ""]
    rows = [[c["key"], c["paper"], c["ours"], verdict_text(c)] for c in comparison]
    lines += [md_table(["quantity", "paper", "ours", "agrees"], rows), ""]
    lines += ["\"agrees (value)\": the paper's number lies within our 95 % interval widened by the stated tolerance "
              "(2 battery points; 10 % of a distance or a collision count; exact for the paper's zero success "
              "counts; wall/UAV ratio 3 ± 1). \"agrees (direction)\": the paper gives only a direction. \"not "
              "significant\": our blocked test or within-configuration slope has p >= 0.05.", "",
              "Quotes (paper, section V):", ""]
    lines += [f"- *{c['key']}*: {c['quote']}" + (f" — {c['note']}" if c["note"] else "")
              + (f" — {c['value'].text}" if c.get("value") is not None and c["value"].text else "")
              for c in comparison]
    lines += ["", "## The paper's numbers that cannot all hold together", ""]
    lines += [f"- {x}" for x in paper_consistency()]
    return lines


def _differences_md(comparison: list[dict], why_text: dict) -> list[str]:
    """Each claim we do not reproduce, with its facts and numbered causes (each cause stated once)."""
    lines = ["", "## Where and why we differ", ""]
    differing = [c for c in comparison if c["agree"] is False or c["sig"] is False]
    if not differing:
        lines += ["Every published claim is reproduced.", ""]
    used: list[str] = []
    for c in differing:
        refs = []
        for w in c["why"]:
            if w in why_text and w not in used:
                used.append(w)
            if w in why_text:
                refs.append(f"[{used.index(w) + 1}]")
        verdict = "differs" if c["agree"] is False else "same direction, not significant here"
        lines += [f"- **{c['key']}** ({verdict}) — paper: {c['paper']}; ours: {c['ours']}. {c['fact']} "
                  f"Possible causes: {' '.join(refs) or '-'}"]
    if used:
        lines += ["", "Causes (stated from the settings these runs used):", ""]
        lines += [f"{i + 1}. {why_text[w]}" for i, w in enumerate(used)]
    return lines


def _figures_md(fd: dict, files: dict) -> list[str]:
    lines = ["## Figures", ""]
    for k, path in files.items():
        lines += [f"![{CAPTIONS[k]}]({path.name})", "", f"*{CAPTIONS[k]}. {fd['n']}.*", ""]
    return lines


def _figure_tables_md(fd: dict, r) -> list[str]:
    """The numbers of Figs. 5-10 as tables."""
    lines = ["### Successes per fleet size (Fig. 5)", ""]
    rows = []
    for n in fd["fleets"]:
        row = [n]
        for s in fd["strategies"]:
            k, m, ci = fd["fig5"][(s, n)]
            row.append(f"{k}/{m} [{ci.low:.1f}, {ci.high:.1f}]" if m and math.isfinite(ci.low) else f"{k}/{m}")
        if {"A", "B"} <= set(fd["strategies"]):
            e = ab_effect(r[r["n_uavs"] == n], "successes")
            row.append(effect_text(e))
        rows.append(row)
    lines += [md_table(["UAVs", *[f"Strategy {s}" for s in fd["strategies"]], "B - A successes per run"], rows), ""]
    lines += ["### Remaining battery (Figs. 6, 7, 10), mean % over UAV missions [95 % stratified interval]", ""]
    rows = [[s, area_label(a), fd["fig6"][(s, a)].fmt(1)] for s in fd["strategies"] for a in fd["areas"]]
    lines += [md_table(["strategy", "area", "remaining battery"], rows), ""]
    rows = [[s, area_label(a)] + [fd["fig7"][(s, a, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]
            for a in fd["areas"]]
    lines += [md_table(["strategy", "area", *[f"wind probability {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    if fd["fig7b"]:
        rows = [[s, area_label(a)] + [effect_text(fd["fig7b"][(s, a, w)]) for w in fd["winds"] if w > 0]
                for s in fd["strategies"] for a in fd["areas"]]
        lines += ["Paired difference to 0 % wind (same configuration and repetition), %-points:", "",
                  md_table(["strategy", "area", *[f"{w * 100:g} %" for w in fd["winds"] if w > 0]], rows), ""]
    rows = [[s] + [fd["fig10"][(s, n)].fmt(1) for n in fd["fleets"]] for s in fd["strategies"]]
    lines += [md_table(["strategy", *[f"{n} UAV" for n in fd["fleets"]]], rows), ""]
    lines += ["### Total distance (Fig. 8), km [95 % stratified interval]", ""]
    rows = [[s] + [fd["fig8"][(s, w)].fmt(1) for w in fd["winds"]] for s in fd["strategies"]]
    lines += [md_table(["strategy", *[f"wind probability {w * 100:g} %" for w in fd["winds"]]], rows), ""]
    lines += ["### Collisions per impact point (Fig. 9), UAVs removed [95 % interval]", ""]
    rows = [[s, area_label(a), fd["fig9"][(s, a, "uav")].fmt(0), fd["fig9"][(s, a, "zone")].fmt(0)]
            for s in fd["strategies"] for a in fd["areas"]]
    lines += [md_table(["strategy", "area", "UAV-UAV", "restricted area (wall)"], rows), ""]
    return lines


def _table2_md(fd: dict, t2: list[dict], r) -> list[str]:
    """Table II with the blocked comparison behind each verdict, and what its p-values are conditional on."""
    lines = ["## Table II - which strategy is better (α = 0.05)", "", f"{fd['n']}.", ""]
    verdicts = [x["better"] if x["better"] != "none" else f"no significant difference ({x['lead']} ahead)"
                for x in t2]
    rows = [[x["metric"], x["A"], x["B"], x["effect"].fmt(3),
             f"[{x['effect'].boot_low:.3g}, {x['effect'].boot_high:.3g}]" if x["n_blocks"] else "n/a",
             f"{x['effect'].d_z:.2f}" if math.isfinite(x["effect"].d_z) else "n/a", p_text(x["p"]), x["n_blocks"],
             ", ".join(f"{d:+.3g}" for d in x["per_layout"]) or "n/a", verdict, "B"]
            for x, verdict in zip(t2, verdicts)]
    lines += [md_table(["metric", "Strategy A", "Strategy B", "B - A per run [t interval]", "bootstrap interval",
                        "d_z", "sign-flip p", "blocks", "B - A per repetition (layout)", "better (ours)", "paper"],
                       rows), ""]
    n_rep = r["rep"].nunique()
    lines += [f"The blocks are {r['cell'].nunique()} configurations x {n_rep} "
              f"repetitions; the repetitions are the layouts, shared by every configuration, so the p-values are "
              f"conditional on these {n_rep} layouts. A claim about layouts in general rests on the per-layout "
              f"column: with {n_rep} layouts, a sign-flip test over layouts cannot go below "
              f"p = {2 / 2 ** n_rep:.2g}, so it needs the same sign in every layout at least.", ""]
    lines += ["Direction: more successes, photos and remaining energy are better; less distance and fewer "
              "collisions are better (the paper's reading). \"with wind\" rows use the runs with a wind "
              "probability above 0.", ""]
    return lines


def sensitivity_md(r, design: dict) -> list[str]:
    """The sensitivity section of a campaign with a ``design:``: per configuration which findings hold, and per
    finding the configurations that flip it."""
    findings = sensitivity_findings(r, design)
    baseline = ", ".join(f"{k} = {v}" for k, v in design["baseline"].items())
    baseline_runs = r[r["config"] == (findings["baseline"] or r["config"].iloc[0])]
    lines = ["## Sensitivity: which assumptions flip which finding", "",
             f"One factor at a time around the baseline ({baseline})"
             + (f", plus the factorial {' x '.join(f'{k} {v}' for k, v in design['factorial'].items())}"
                if design.get("factorial") else "")
             + f". Each configuration runs the whole grid ({n_text(baseline_runs)} "
               "per configuration). A finding *holds* when its statistic has the paper's sign and is significant "
               "(blocked sign-flip test, α = 0.05) or, for counts the paper gives, equals it.", ""]
    keys = list(findings["tests"])
    rows = []
    for c, holds in findings["table"].items():
        rows.append([findings["labels"][c], ", ".join(x.split(":")[0] for x in findings["roles"][c]) or "-",
                     *["✓" if holds[k][0] else ("✗" if holds[k][0] is False else "n/a") for k in keys]])
    lines += [md_table(["configuration", "design", *[findings["tests"][k] for k in keys]], rows), ""]
    lines += ["Per finding, the configurations that flip it relative to the baseline (with the evidence in the "
              "flipped configuration; baseline evidence first):", ""]
    for k in keys:
        at_baseline = findings["table"][findings["baseline"]][k] if findings["baseline"] else (None, "", None)
        state = "holds" if at_baseline[0] else ("does not hold" if at_baseline[0] is False else "n/a")
        flipped = "; ".join(f"*{findings['labels'][c]}* ({flip_kind(at_baseline, findings['table'][c][k])}): "
                            f"{findings['table'][c][k][1]}" for c in findings["flips"][k]) or "no factor flips it"
        lines += [f"- **{findings['tests'][k]}** — baseline {state} ({at_baseline[1]}). Flipped by: {flipped}."]
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
