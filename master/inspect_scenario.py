"""``inspect``: what a scenario contains and the master settings a run would use."""
from __future__ import annotations

from pathlib import Path

from .algorithms import ALGORITHMS
from .algorithms.ordering import algebraic_loops, gauss_seidel_order, loop_cycles
from .execution import prepare
from .plan.bare_fmu import is_bare_fmu
from .settings import resolve_settings


def inspect(scenario, **overrides) -> dict:
    p = prepare(Path(scenario))
    model, plan, shown_as = p.model, p.plan, p.shown_as
    try:
        info: dict = {"scenario": shown_as, "name": model.name, "ssp_version": model.version, "components": {}}
        for name, comp in model.components.items():
            fmu = plan.fmus[name]
            md = fmu.md
            info["components"][name] = {
                "source": comp.source, "fmi_version": md.fmiVersion,
                "kind": fmu.kind,
                "model_name": md.modelName, "generation_tool": md.generationTool, "sha256": fmu.sha256,
                "connectors": [{"name": c.name, "kind": c.kind, "type": c.type or plan.variables[name][c.name].fmi_type,
                                "unit": c.unit or plan.variables[name][c.name].unit}
                               for c in comp.connectors.values()],
            }
        info["connections"] = [{"from": ln.src.qualified, "to": ln.dst.qualified,
                                **({"factor": ln.factor, "offset": ln.offset}
                                   if (ln.factor, ln.offset) != (1.0, 0.0) else {}),
                                **({"mapping": ln.mapping} if ln.mapping else {})} for ln in plan.links]
        info["parameters"] = [{"variable": v.qualified, "value": value, "from": origin}
                              for v, value, origin in plan.params]
        info["default_experiment"] = {"start_time": model.start_time, "stop_time": model.stop_time}
        if is_bare_fmu(scenario):     # the system around it is ours: show the FMU's own experiment, not that
            info["bare_fmu"] = True
            for c in info["components"].values():
                c["source"] = shown_as          # not the member of the archive made for it
            de = next(iter(plan.fmus.values())).md.defaultExperiment
            given = {k: getattr(de, f"{k}Time", None) if de is not None else None for k in ("start", "stop")}
            info["default_experiment"] = {f"{k}_time": float(v) if v not in (None, "") else None
                                          for k, v in given.items()}
        try:
            st = resolve_settings(model, shown_as, fmus=plan.fmus, **overrides)
            info["settings"] = {"algorithm": st.algorithm, "step_size": st.step, "step_size_from": st.step_source,
                                "start_time": st.start, "stop_time": st.stop, "steps": st.steps,
                                "record_interval": st.step * st.record_every, "step_multiples": st.step_multiples}
        except Exception as exc:   # inspect still shows everything else when settings are incomplete
            info["settings"] = {"error": str(exc)}
        so = gauss_seidel_order(plan, list(plan.fmus))
        names = list(plan.fmus)
        info["gauss_seidel_order"] = [names[i] for i in so.order]
        info["gauss_seidel_loops_broken_at"] = [f"{a} -> {b}" for a, b in so.broken]
        info["algebraic_loops"] = algebraic_loops(plan)
        info["algebraic_loop_cycles"] = [[{"from": a, "to": b, "via": how} for a, b, how in cyc]
                                         for cyc in loop_cycles(plan)]
        info["annotations"] = [] if info.get("bare_fmu") else sorted(k for k in model.annotations if k)
        return info
    finally:
        p.source.close()


def format_inspect(info: dict) -> str:
    what = ("a bare FMU, run as a system of this one component" if info.get("bare_fmu")
            else f"SSP {info['ssp_version']}, system {info['name']}")
    lines = [f"scenario   {info['scenario']}  ({what})", "", "components:"]
    for name, c in info["components"].items():
        lines.append(f"  {name}: {c['source']}  FMI {c['fmi_version']} {c['kind']}  model {c['model_name']}"
                     f"  tool {c['generation_tool'] or '-'}")
        for k in c["connectors"]:
            unit = f" [{k['unit']}]" if k["unit"] else ""
            lines.append(f"      {k['kind']:<20} {k['type']:<12} {k['name']}{unit}")
    lines.append("")
    lines.append("connections:")
    for c in info["connections"]:
        extra = f"  (x{c['factor']:g} {c['offset']:+g})" if "factor" in c else ""
        extra += f"  map {c['mapping']}" if "mapping" in c else ""
        lines.append(f"  {c['from']} -> {c['to']}{extra}")
    lines.append("")
    lines.append("parameters:")
    for p in info["parameters"]:
        lines.append(f"  {p['variable']} = {p['value']!r}  ({p['from']})")
    de = info["default_experiment"]
    whose = "the FMU's default experiment" if info.get("bare_fmu") else "default experiment"
    lines += ["", f"{whose}: start {de['start_time']}, stop {de['stop_time']}", "", "master settings:"]
    for k, v in info["settings"].items():
        lines.append(f"  {k}: {v}")
    lines.append(f"  gauss-seidel order: {' -> '.join(info['gauss_seidel_order'])}")
    if info["gauss_seidel_loops_broken_at"]:
        lines.append(f"  gauss-seidel loops broken at: {', '.join(info['gauss_seidel_loops_broken_at'])}")
    alg = info["settings"].get("algorithm", "jacobi")
    for lp, cyc in zip(info["algebraic_loops"], info["algebraic_loop_cycles"]):
        lines.append(_describe_loop(lp, cyc, alg))
    if info["annotations"]:
        lines.append(f"  annotations: {', '.join(info['annotations'])}")
    return "\n".join(lines)


def _describe_loop(members: list[str], cycle: list[dict], algorithm: str) -> str:
    """An algebraic loop as its components, one cycle through it, and what it means for the run."""
    comps = sorted({q.rsplit(".", 1)[0] for q in members})
    arrows = {"connection": " -> ", "declared": " => ", "assumed": " ~> "}
    path = cycle[0]["from"] + "".join(arrows[e["via"]] + e["to"] for e in cycle)
    assumed = sorted({e["from"].rsplit(".", 1)[0] for e in cycle if e["via"] == "assumed"})
    text = [f"  algebraic loop between {', '.join(comps)} ({len(members)} ports), e.g. {path}",
            "    (-> connection, => declared output dependency, ~> assumed: the FMU declares no dependencies)"]
    if assumed:
        text.append(f"    {', '.join(assumed)} declare{'s' if len(assumed) == 1 else ''} no output dependencies, so "
                    "every output counts as depending on every input; if they do not, there is no loop")
    text.append("    initialization iterates it until the values settle; "
                + ALGORITHMS.get(algorithm, element="algorithm").loop_treatment)
    return "\n".join(text)
