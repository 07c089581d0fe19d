"""``run_study``: the grid algorithm x extrapolation order x step of one scenario, as a campaign (resumable,
local workers or Dask), compared with a reference; writes study.csv and the figures.

Layout of the study folder: ``study_campaign.yaml`` (the campaign the study runs; its runs are
``{algorithm, extrapolation, step}``), the campaign's own files (campaign.json, runs/<run_id>/ with each run's
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
from .compare import COLUMNS, add_observed_orders, run_errors
from .reference import Reference, parse_reference, read_samples

CAMPAIGN_FILE = "study_campaign.yaml"
TABLE = "study.csv"


@dataclass
class StudySummary:
    output: Path
    runs: int = 0
    ran_now: int = 0
    failed: int = 0
    table: Path | None = None
    figures: list = field(default_factory=list)
    skipped: list = field(default_factory=list)     # grid points that do not exist (extrapolation of iterative)
    campaign: object = None

    def describe(self) -> str:
        parts = [f"Study: {self.runs} runs ({self.ran_now} run now, {self.failed} failed)."]
        if self.skipped:
            parts.append(f"Left out {len(self.skipped)} grid point(s) whose algorithm takes no extrapolation "
                         f"({', '.join(sorted(set(self.skipped)))}).")
        parts.append(f"Table: {self.table}. Figures: {', '.join(str(p.name) for p in self.figures) or 'none'}.")
        return " ".join(parts)


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


def _takes_extrapolation(algorithm: str) -> bool:
    from ..algorithms import get_algorithm
    return bool(getattr(get_algorithm(algorithm), "honours_extrapolation", True))


def study_runs(algorithms, extrapolations, steps, reference: Reference) -> tuple[list[dict], list[str], dict | None]:
    """(the grid's runs' parameters in order, the grid points left out, the fine reference run's parameters:
    a run of its own unless the grid has it)."""
    runs, skipped = [], []
    for a in algorithms:
        for k in extrapolations:
            if k and not _takes_extrapolation(a):
                skipped.append(f"{a} K={k}")
                continue
            runs.extend({"algorithm": a, "extrapolation": int(k), "step": float(h)} for h in steps)
    fine = None
    if reference.kind == "fine":
        fine = {"algorithm": "iterative", "extrapolation": 0, "step": reference.fine_step}
    return runs, skipped, fine


def run_study(scenario, *, algorithms, extrapolations, steps, reference: str, record=None, output,
              workers=None, scheduler=None, stop_time=None, progress=True) -> StudySummary:
    from ..campaign.runner import run_campaign
    from ..campaign.spec import canonical_json, run_id_for
    scenario = Path(scenario)
    if not scenario.exists():
        raise CosimError(f"scenario not found: {scenario}", element="study")
    algorithms, extrapolations, steps = list(algorithms), [int(k) for k in extrapolations], list(steps)
    _check_grid(algorithms, extrapolations, steps)
    ref = parse_reference(reference)
    runs, skipped, fine = study_runs(algorithms, extrapolations, steps, ref)
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
    # JSON is YAML: the campaign file as the campaign machinery reads it
    camp_file.write_text(canonical_json({"name": "study", "description": f"coupling study of {scenario}",
                                         "scenario": str(scenario.resolve()),
                                         "runs": runs + ([fine] if fine is not None and fine not in runs else []),
                                         "run": fixed,
                                         "keep": "all"}) + "\n", encoding="utf-8")
    camp = run_campaign(camp_file, output=out, workers=workers, scheduler=scheduler, progress=progress)
    s = StudySummary(out, runs=camp.total, ran_now=camp.ran_now, failed=camp.failed, skipped=skipped, campaign=camp)

    if fine is not None:
        fine_dir = out / "runs" / run_id_for(fine, 0)
        if not (fine_dir / "results.parquet").is_file():
            raise CosimError(f"the fine reference run (iterative, step {fine['step']:g}) has no results: "
                             f"{_record(out, fine).get('error') or 'it did not finish'}", element="--reference")
        ref.frame = read_samples(fine_dir / "results.parquet", "--reference")
    rows, frames = [], {}
    for params in runs:
        rows.extend(_rows(out, params, ref, frames))
    if not any(math.isfinite(r["error_max"]) for r in rows):
        if all(r["outcome"] != "completed" for r in rows):
            raise CosimError("every run of the study failed (see study.csv and runs/*.json)", element="study")
    add_observed_orders(rows)
    s.table = _write_table(out / TABLE, rows)
    s.figures = [figures.error_vs_step(rows, out / "error_vs_step.png"),
                 figures.work_precision(rows, out / "work_precision.png")]
    energy = figures.energy_residual(frames, out / "energy_residual.png")
    if energy is not None:
        s.figures.append(energy)
    return s


def _record(out: Path, params: dict) -> dict:
    from ..campaign.spec import run_id_for
    p = out / "runs" / f"{run_id_for(params, 0)}.json"
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def _rows(out: Path, params: dict, ref: Reference, frames: dict) -> list[dict]:
    """The rows of one run: one per signal the run recorded and the reference knows."""
    from ..campaign.spec import run_id_for
    rec = _record(out, params)
    run_dir = out / "runs" / run_id_for(params, 0)
    base = {**params, "fmu_calls": (rec.get("fmu_calls") or {}).get("do_step_total"), "wall_s": math.nan,
            "outcome": rec.get("outcome", "missing")}
    try:
        meta = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))
        base["wall_s"] = float(meta.get("wall_time_s", math.nan))
    except (OSError, ValueError):
        pass
    if rec.get("outcome") != "completed" or not (run_dir / "results.parquet").is_file():
        base["outcome"] = f"{base['outcome']}: {rec.get('error') or 'no results'}"
        return [{**base, "signal": "", "error_max": math.nan, "error_rms": math.nan}]
    frame = read_samples(run_dir / "results.parquet", "study")
    label = f"{params['algorithm']}, K={params['extrapolation']}, h={params['step']:g}"
    frames[label] = frame
    steps = run_dir / "steps.csv"       # variable-step algorithms log each accepted step there (ECCO: energy residual)
    if steps.is_file():
        import pandas as pd
        frames[f"{label} (steps)"] = pd.read_csv(steps)
    recorded = [c for c in frame.columns if c != "time"]
    known = ref.values(frame["time"].to_numpy(dtype=float)[:1], recorded)
    signals = [c for c in recorded if c in known]
    if not signals:
        raise CosimError(f"the reference {ref.text} gives none of the recorded signals ({', '.join(recorded)}); "
                         "choose them with --record", element="--reference")
    errors = run_errors(frame, ref, signals)
    return [{**base, "signal": sig, "error_max": e_max, "error_rms": e_rms} for sig, (e_max, e_rms) in errors.items()]


def _write_table(path: Path, rows: list[dict]) -> Path:
    def cell(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else repr(v)
        return "" if v is None else v
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([cell(r.get(c)) for c in COLUMNS])
    tmp.replace(path)
    return path
