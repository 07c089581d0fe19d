"""``run_study``: the grid algorithm x extrapolation order x step (x any algorithm setting given as an axis) of one
scenario, as a campaign (resumable, local workers or Dask), compared with a reference; writes study.csv and the
figures.

Layout of the study folder: ``study_campaign.yaml`` (the campaign the study runs; its runs are
``{algorithm, extrapolation, step, <settings swept>}``; a setting is swept only for the algorithms that read
it, ``AlgorithmOption.applies_to``), the campaign's own files (campaign.json, runs/<run_id>/ with each run's
results, results.parquet), ``study.csv`` and ``error_vs_step.png``, ``work_precision.png`` and, when a run
records an energy residual, ``energy_residual.png``. Running the same command again runs only what is missing
(the campaign's records) and rewrites the table and figures.
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import CosimError
from . import figures
from .compare import COLUMNS, add_observed_orders, diverged, run_errors
from .reference import Reference, parse_reference, read_samples

CAMPAIGN_FILE = "study_campaign.yaml"
TABLE = "study.csv"
#: a reference whose own estimated error is above this share of an error it measures is not trusted for it
REFERENCE_SHARE = 0.1


@dataclass
class StudySummary:
    output: Path
    runs: int = 0
    ran_now: int = 0
    failed: int = 0
    diverged: int = 0
    table: Path | None = None
    figures: list = field(default_factory=list)
    skipped: list = field(default_factory=list)     # grid points that do not exist (extrapolation of iterative)
    warnings: list = field(default_factory=list)
    campaign: object = None

    def describe(self) -> str:
        parts = [f"Study: {self.runs} runs ({self.ran_now} run now, {self.failed} failed, "
                 f"{self.diverged} diverged)."]
        if self.skipped:
            parts.append(f"Left out {len(self.skipped)} grid point(s) whose algorithm takes no extrapolation "
                         f"({', '.join(sorted(set(self.skipped)))}).")
        parts.append(f"Table: {self.table}. Figures: {', '.join(str(p.name) for p in self.figures) or 'none'}.")
        return "\n".join([" ".join(parts), *(f"warning: {w}" for w in self.warnings)])


def _check_grid(algorithms, extrapolations, steps) -> None:
    from ..algorithm_options import ALGORITHM_OPTIONS
    from ..algorithms import ALGORITHMS
    if not algorithms or not extrapolations or not steps:
        raise CosimError("give at least one algorithm, extrapolation order and step", element="study")
    for a in algorithms:
        if a not in ALGORITHMS:
            raise CosimError(f"unknown algorithm {a!r} (known: {', '.join(ALGORITHMS.names())})", element="--algorithm")
    for k in extrapolations:
        ALGORITHM_OPTIONS["extrapolation"].parse(k, "--extrapolation")
    for h in steps:
        if isinstance(h, bool) or not isinstance(h, (int, float)) or not (math.isfinite(h) and h > 0):
            raise CosimError(f"a step must be a positive number of seconds, got {h!r}", element="--step")
    for what, values in (("--algorithm", algorithms), ("--extrapolation", extrapolations), ("--step", steps)):
        if len(set(values)) != len(values):
            raise CosimError("a value is given twice", element=what)


def _check_settings(settings: dict | None) -> dict[str, list]:
    """name -> the parsed values of every algorithm setting swept (``extrapolation`` is its own axis)."""
    from ..algorithm_options import ALGORITHM_OPTIONS
    out = {}
    for name, values in (settings or {}).items():
        if values is None:
            continue
        opt = ALGORITHM_OPTIONS.get(name)
        if opt is None or name == "extrapolation":
            raise CosimError(f"not an algorithm setting a study sweeps: {name!r}", element="study")
        values = [opt.parse(v, opt.flag) for v in (values if isinstance(values, (list, tuple)) else [values])]
        if not values:
            continue
        if len(set(map(repr, values))) != len(values):
            raise CosimError("a value is given twice", element=opt.flag)
        out[name] = values
    return out


def _takes_extrapolation(algorithm: str) -> bool:
    from ..algorithms import get_algorithm
    return bool(getattr(get_algorithm(algorithm), "honours_extrapolation", True))


def variable_step_algorithms(algorithms) -> set[str]:
    """The algorithms whose ``step`` is the record grid, not the step they take (adaptive, ecco)."""
    from ..algorithms import get_algorithm
    from ..algorithms.adaptive import Adaptive
    return {a for a in algorithms if isinstance(get_algorithm(a), Adaptive)}


def study_runs(algorithms, extrapolations, steps, reference: Reference,
               settings: dict | None = None) -> tuple[list[dict], list[str], list[dict]]:
    """(the grid's runs' parameters in order, the grid points left out, the reference's own runs: those of a
    fine reference that the grid does not have)."""
    import itertools

    from ..algorithm_options import ALGORITHM_OPTIONS
    settings = settings or {}
    runs, skipped = [], []
    for a in algorithms:
        axes = {n: v for n, v in settings.items() if not ALGORITHM_OPTIONS[n].applies_to
                or a in ALGORITHM_OPTIONS[n].applies_to}
        for k in extrapolations:
            if k and not _takes_extrapolation(a):
                skipped.append(f"{a} K={k}")
                continue
            for combo in itertools.product(*axes.values()):
                runs.extend({"algorithm": a, "extrapolation": int(k), "step": float(h), **dict(zip(axes, combo))}
                            for h in steps)
    return runs, skipped, [r for r in reference.runs() if r not in runs]


def campaign_text(data: dict) -> str:
    """The study's campaign file: YAML whose numbers read back as the same numbers (a JSON float such as 5e-05
    is a string under YAML 1.1's float rule, which wants a dot and a signed exponent)."""
    from .. import yamlio
    return yamlio.dump(data, sort_keys=True, default_flow_style=False, allow_unicode=True)


def run_study(scenario, *, algorithms, extrapolations, steps, reference: str, record=None, output,
              workers=None, scheduler=None, stop_time=None, progress=True, settings=None) -> StudySummary:
    """``settings``: algorithm setting name -> the values to sweep (each applied to the algorithms that read it)."""
    from ..campaign.runner import run_campaign
    scenario = Path(scenario)
    if not scenario.exists():
        raise CosimError(f"scenario not found: {scenario}", element="study")
    algorithms, extrapolations, steps = list(algorithms), [int(k) for k in extrapolations], list(steps)
    _check_grid(algorithms, extrapolations, steps)
    settings = _check_settings(settings)
    ref = parse_reference(reference)
    runs, skipped, ref_runs = study_runs(algorithms, extrapolations, steps, ref, settings)
    if not runs:
        raise CosimError("no run left in the grid (every algorithm refuses the extrapolation orders given)",
                         element="--extrapolation")
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    fixed = {"csv": False, "log_level": "error"}
    if record:
        fixed["record"] = list(record)
    if stop_time is not None:
        fixed["stop_time"] = stop_time
    camp_file = out / CAMPAIGN_FILE
    camp_file.write_text(campaign_text({"name": "study", "description": f"coupling study of {scenario}",
                                        "scenario": str(scenario.resolve()), "runs": runs + ref_runs,
                                        "run": fixed, "keep": "all"}), encoding="utf-8")
    camp = run_campaign(camp_file, output=out, workers=workers, scheduler=scheduler, progress=progress)
    s = StudySummary(out, runs=camp.total, ran_now=camp.ran_now, failed=camp.failed, skipped=skipped, campaign=camp)

    ref_failure = _load_reference_runs(out, ref)
    axes = list(settings)
    rows, frames = [], {}
    for params in runs:
        rows.extend(_rows(out, params, None if ref_failure else ref, frames, axes))
    for r in rows:
        r["reference"] = ref_failure or ref.describe()
    s.diverged = len({_key(r, axes) for r in rows if r["outcome"].startswith("diverged")})
    if ref_failure:
        s.table = _write_table(out / TABLE, rows, axes)
        raise CosimError(f"{ref_failure}; {TABLE} lists the grid runs without errors", element="--reference")
    add_observed_orders(rows, axes, variable_step_algorithms(algorithms))
    s.warnings = _reference_warnings(rows, ref)
    s.table = _write_table(out / TABLE, rows, axes)
    if not any(math.isfinite(r["error_max"]) for r in rows):
        if all(r["outcome"] != "completed" for r in rows):
            raise CosimError(f"every run of the study failed (see {out / TABLE} and runs/*.json)", element="study")
    title = f"{scenario.name}; reference {ref.describe()}"
    s.figures = [figures.error_vs_step(rows, out / "error_vs_step.png", title, axes),
                 figures.work_precision(rows, out / "work_precision.png", title, axes)]
    tolerance = figures.error_vs_setting(rows, out / "error_vs_tolerance.png", title, axes)
    if tolerance is not None:
        s.figures.append(tolerance)
    energy = figures.energy_residual(frames, out / "energy_residual.png", title)
    if energy is not None:
        s.figures.append(energy)
    return s


def _key(row: dict, axes: list[str]) -> tuple:
    return (row["algorithm"], row["extrapolation"], row["step"], *(repr(row.get(a)) for a in axes))


def _load_reference_runs(out: Path, ref: Reference) -> str | None:
    """Read a fine reference's runs into ``ref``; the reason when it has none (None: the reference is ready)."""
    if ref.kind != "fine":
        return None
    frames = []
    for params in ref.runs():
        path = _run_dir(out, params) / "results.parquet"
        if not path.is_file():
            return (f"the reference {ref.text} has no results (its run at step {params['step']:g}: "
                    f"{_record(out, params).get('error') or 'it did not finish'})")
        frames.append(read_samples(path, "--reference"))
    ref.set_fine(*frames)
    return None


def _reference_warnings(rows: list[dict], ref: Reference) -> list[str]:
    """One line per signal whose reference error is not well below (REFERENCE_SHARE) an error it measures."""
    worst: dict[str, tuple[float, dict]] = {}
    for r in rows:
        e, e_ref = r["error_max"], r.get("reference_error", math.nan)
        if r["signal"] and math.isfinite(e) and e > 0 and math.isfinite(e_ref) and e_ref > REFERENCE_SHARE * e:
            if r["signal"] not in worst or e < worst[r["signal"]][0]:
                worst[r["signal"]] = (e, r)
    return [f"the reference's own error of {sig} ({r['reference_error']:.3g}, {ref.text}) is more than "
            f"{REFERENCE_SHARE:g} of the error it measures for {r['algorithm']} K={r['extrapolation']} "
            f"h={r['step']:g} ({e:.3g}): that error and its order are not to be trusted (a finer reference fixes it)"
            for sig, (e, r) in sorted(worst.items())]


def _run_dir(out: Path, params: dict) -> Path:
    from ..campaign.spec import run_id_for
    return out / "runs" / run_id_for(params, 0)


def _record(out: Path, params: dict) -> dict:
    from ..campaign.spec import run_id_for
    p = out / "runs" / f"{run_id_for(params, 0)}.json"
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _counts(meta: dict) -> dict:
    """Steps, coupling iterations and rejected steps of a run (run.json ``algorithm_info``; empty where the
    algorithm has none)."""
    info = meta.get("algorithm_info") or {}
    steps = info.get("steps")
    return {"steps": steps if isinstance(steps, int) else meta.get("steps"),
            "iterations": info.get("iterations_total"), "rejected": info.get("rejected")}


def _rows(out: Path, params: dict, ref: Reference | None, frames: dict, axes: list[str]) -> list[dict]:
    """The rows of one run: one per signal the run recorded and the reference knows (``ref`` None: the
    reference failed, one row per recorded signal without errors)."""
    rec = _record(out, params)
    run_dir = _run_dir(out, params)
    base = {**params, "fmu_calls": (rec.get("fmu_calls") or {}).get("do_step_total"), "wall_s": math.nan,
            "outcome": rec.get("outcome", "missing"), "reference_error": math.nan,
            "reference_magnitude": math.nan}
    try:
        meta = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
        base["wall_s"] = float(meta.get("wall_time_s", math.nan))
        base.update(_counts(meta))
    except (OSError, ValueError):
        pass
    empty = {"error_max": math.nan, "error_rms": math.nan}
    if rec.get("outcome") != "completed" or not (run_dir / "results.parquet").is_file():
        error = rec.get("error") or "no results"
        state = "diverged" if "non-finite" in error else base["outcome"]
        base["outcome"] = f"{state}: {error}"
        return [{**base, "signal": "", **empty}]
    frame = read_samples(run_dir / "results.parquet", "study")
    recorded = [c for c in frame.columns if c != "time"]
    if ref is None:
        return [{**base, "signal": sig, **empty} for sig in recorded]
    label = _label(params, axes) + f", h={params['step']:g}"
    frames[label] = frame
    steps = run_dir / "steps.csv"       # variable-step algorithms log each accepted step there (ECCO: energy residual)
    if steps.is_file():
        import pandas as pd
        frames[f"{label} (steps)"] = pd.read_csv(steps)
    known = ref.values(frame["time"].to_numpy(dtype=float)[:1], recorded)
    signals = [c for c in recorded if c in known]
    if not signals:
        raise CosimError(f"the reference {ref.text} gives none of the recorded signals ({', '.join(recorded)}); "
                         "choose them with --record", element="--reference")
    errors = run_errors(frame, ref, signals)
    if diverged(errors):
        base["outcome"] = "diverged"
    t = frame["time"].to_numpy(dtype=float)
    t = t[ref.covers(t)]
    return [{**base, "signal": sig, "error_max": e_max, "error_rms": e_rms, "reference_error": ref.error(sig, t),
             "reference_magnitude": scale} for sig, (e_max, e_rms, scale) in errors.items()]


def _label(params: dict, axes: list[str]) -> str:
    """A run's algorithm and settings, without its step (legend entries, figure series)."""
    return figures.series_label(params, axes)


def _write_table(path: Path, rows: list[dict], axes: list[str]) -> Path:
    def cell(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else repr(v)
        return "" if v is None else v
    at = COLUMNS.index("step") + 1
    columns = COLUMNS[:at] + list(axes) + COLUMNS[at:]
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow([cell(r.get(c)) for c in columns])
    tmp.replace(path)
    return path
