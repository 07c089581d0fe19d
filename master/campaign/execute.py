"""One campaign run, as executed by a worker (local worker process or Dask worker).

:func:`execute_run` takes a task (a plain dict, see :func:`master.campaign.runner.make_task`) and
returns the run's record (a JSON-safe dict); it never raises for a failure of the run itself: a
CosimError, a bad parameter or any Python exception becomes ``outcome: failed`` with a one-line
``error``.  A crash of the process (an FMU calling abort(), a segfault) cannot be caught here; the
pool that ran the task records it (:func:`failure_record`).

``used`` in the record holds the SHA-256 of the scenario file as this worker read it and of the FMUs
the run loaded, so that the campaign can tell when an input changed while the campaign was running.

The run's own files go to ``runs/<run_id>/`` (cleared first, so a run interrupted earlier leaves no
trace); with ``keep: summary`` only the small files are kept afterwards.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import shutil
import socket
import time
import traceback
from pathlib import Path

from ..results import final_values

__all__ = ["execute_run", "failure_record", "kept_after_run", "SUMMARY_FILES"]

#: what ``keep: summary`` keeps of a run folder (and the scenario kind's ``summary_files``)
SUMMARY_FILES = ("run.json", "summary.json", "summary.csv", "events.csv", "fmu.log")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def base_record(task: dict) -> dict:
    return {"format": 1, "campaign": task["campaign"], "run_id": task["run_id"], "index": task["index"],
            "params": task["params"], "rep": task["rep"], "seed": task["seed"], "outcome": "failed", "error": None,
            "wall_time_s": None, "inputs": task["inputs"], "inputs_sha256": task["inputs_sha256"],
            "scenario_sha256": None, "fmus": {}, "worker": None, "finished_at": None}


def failure_record(task: dict, reason: str, wall_time_s: float | None = None, worker: str | None = None) -> dict:
    """The record of a run whose worker could not report (process died, timed out, Dask gave up)."""
    rec = base_record(task)
    rec["error"] = _one_line(reason)
    rec["wall_time_s"] = wall_time_s
    rec["worker"] = worker
    rec["finished_at"] = _now()
    return rec


def kept_after_run(task: dict, name: str, kind) -> bool:
    """Does the run folder keep the file ``name`` once the run is over (``_prune``)?  A scenario kind need not
    write a file to disk that would be deleted unread."""
    return task.get("keep", "all") == "all" or name in SUMMARY_FILES or name in kind.summary_files


def _prune(out: Path, keep: str, kept: tuple):
    if keep == "all" or not out.is_dir():
        return
    for p in out.iterdir():
        if p.name in SUMMARY_FILES or p.name in kept:
            continue
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            try:
                p.unlink()
            except OSError:
                pass


def execute_run(task: dict) -> dict:
    """Run one campaign run; returns its record (never raises for a failure of the run)."""
    from ..errors import CosimError
    from ..runner import run as run_scenario
    from ..scenario_kinds import SCENARIO_KINDS
    t0 = time.perf_counter()
    rec = base_record(task)
    rec["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    used: dict = {}
    kind = None
    out = Path(task["out_dir"])
    cdir = str(task["campaign_dir"]).rstrip(os.sep) + os.sep
    try:
        if out.exists():
            shutil.rmtree(out)
        out.mkdir(parents=True)
        opts = task["options"]
        from .spec import ALGORITHM_RUN_OPTIONS
        kw = {k: opts[k] for k in ("start_time", "record_interval", "record", "log_level", "step_multiples",
                                   *ALGORITHM_RUN_OPTIONS) if k in opts}
        kw["options_source"] = "campaign"
        kw["reuse_structure"] = True        # a worker runs the same few systems with other values
        kw.setdefault("log_level", "error")
        kw["write_csv"] = bool(opts.get("csv", True))
        kind = SCENARIO_KINDS.get(task["kind"])
        if task.get("keep", "all") == "summary":
            kw["products"] = "summary"       # no map or trajectory that pruning would delete anyway
            if not kind.records_final_values:
                kw["sinks"] = ["memory"]     # nor results.parquet: the same rows, never written to disk
        run = kind.prepare_run(task, out, used)
        kw.update(run.options)
        # the folder is the run's own (cleared above); the kind may have put the run's scenario in it
        res = run_scenario(run.scenario, output=str(out), params=run.params, seed=run.seed, raise_on_error=False,
                           output_prepared=True, **kw)
        meta = res.metadata
        oc = meta.get("outcome")
        rec["outcome"] = "completed" if oc == "completed" else ("interrupted" if oc == "interrupted" else "failed")
        if oc != "completed":
            rec["error"] = meta.get("error") or f"run ended with outcome {oc!r}"
        rec["scenario_sha256"] = meta.get("scenario_sha256")
        rec["fmus"] = {k: v.get("sha256") for k, v in (meta.get("fmus") or {}).items()}
        for k in ("steps", "step_size", "stop_time", "algorithm", "last_time", "failed_at", "fmu_calls",
                  "algorithm_options", "algorithm_info"):
            if k in meta:
                rec[k] = meta[k]
        if meta.get("monitor_errors"):
            rec["monitor_errors"] = meta["monitor_errors"]
    except CosimError as exc:
        rec["outcome"], rec["error"] = "failed", str(exc)
    except Exception as exc:   # noqa: BLE001 - any failure of one run is that run's result
        rec["outcome"], rec["error"] = "failed", _one_line(f"{type(exc).__name__}: {exc}")
        rec["traceback"] = traceback.format_exc(limit=-8)
    if rec["error"]:
        rec["error"] = _one_line(rec["error"].replace(cdir, ""))
    used["fmus"] = sorted({h for h in rec["fmus"].values() if h})
    from .spec import code_sha256
    used["code_sha256"] = code_sha256()      # a Dask worker may run another installed version
    rec["used"] = used
    summary = out / "summary.json"
    if summary.is_file():
        try:
            rec["summary"] = json.loads(summary.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            rec.setdefault("monitor_errors", []).append(f"summary.json unreadable: {exc}")
    if kind is None or kind.records_final_values:
        rec["final"] = final_values(out)
    _prune(out, task.get("keep", "all"), kind.summary_files if kind is not None else ())
    rec["wall_time_s"] = time.perf_counter() - t0
    rec["finished_at"] = _now()
    return rec
