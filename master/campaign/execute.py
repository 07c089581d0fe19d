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
import hashlib
import json
import math
import os
import shutil
import socket
import time
import traceback
from pathlib import Path

__all__ = ["execute_run", "failure_record", "SUMMARY_FILES"]

#: what ``keep: summary`` keeps of a run folder
SUMMARY_FILES = ("run.json", "summary.json", "summary.csv", "events.csv", "photos.csv", "scenario.yaml", "fmu.log")


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


def _set_path(data: dict, key: str, value, shown: str):
    from ..errors import ScenarioError
    parts = key.split(".")
    d = data
    for i, p in enumerate(parts[:-1]):
        nxt = d.get(p)
        if nxt is None:
            nxt = d[p] = {}
        if not isinstance(nxt, dict):
            raise ScenarioError(f"cannot set {key!r}: {'.'.join(parts[:i + 1])} is not a mapping", file=shown,
                                element=key)
        d = nxt
    d[parts[-1]] = value


def _build_uav(task: dict, out: Path, used: dict) -> Path:
    """The run's UAV scenario: base YAML + overrides + seed -> runs/<id>/scenario.yaml -> scenario.ssp."""
    import yaml

    from ..errors import ScenarioError
    from ..uav.build import build_ssp
    from .. import yamlio
    from ..uav_scenario import scenario_from_dict
    src = Path(task["scenario"])
    try:
        raw = src.read_bytes()
        used["scenario_sha256"] = hashlib.sha256(raw).hexdigest()
        data = yamlio.load(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ScenarioError(f"cannot read the scenario: {exc}", file=str(src)) from None
    if not isinstance(data, dict):
        raise ScenarioError("expected a mapping of scenario fields", file=str(src))
    for k, v in task["overrides"].items():
        _set_path(data, k, v, str(src))
    data["seed"] = int(task["seed"])
    # a campaign run ends when its fleet has landed (the summary is the same; the idle rest is skipped)
    data.setdefault("end_when_all_landed", True)
    head = (f"# campaign {task['campaign']}, run {task['run_id']} (rep {task['rep']}, seed {task['seed']})\n"
            f"# base scenario: {task['inputs']['scenario']}; "
            f"parameters: {json.dumps(task['params'], sort_keys=True)}\n")
    yml = out / "scenario.yaml"
    yml.write_text(head + yamlio.dump(data, sort_keys=False, default_flow_style=None), encoding="utf-8")
    scn = scenario_from_dict(data, yml)       # what was just written, without parsing it again
    return build_ssp(scn, out / "scenario.ssp")


def _final_values(out: Path) -> dict:
    """Last recorded value of every numeric column of results.parquet (generic SSP campaigns)."""
    p = out / "results.parquet"
    if not p.is_file():
        return {}
    import pyarrow.parquet as pq
    try:
        pf = pq.ParquetFile(str(p))
        if pf.metadata.num_rows == 0:
            return {}
        t = pf.read_row_group(pf.num_row_groups - 1)
    except Exception:   # noqa: BLE001 - a truncated file after a failure
        return {}
    out_d = {}
    for name in t.column_names:
        col = t.column(name)
        if len(col) == 0:
            continue
        v = col[len(col) - 1].as_py()
        if isinstance(v, bool):
            out_d[name] = v
        elif isinstance(v, (int, float)):
            out_d[name] = v if not (isinstance(v, float) and not math.isfinite(v)) else None
    return out_d


def _prune(out: Path, keep: str):
    if keep == "all" or not out.is_dir():
        return
    for p in out.iterdir():
        if p.name in SUMMARY_FILES:
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
    import master
    from ..errors import CosimError
    t0 = time.perf_counter()
    rec = base_record(task)
    rec["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    used: dict = {}
    out = Path(task["out_dir"])
    cdir = str(task["campaign_dir"]).rstrip(os.sep) + os.sep
    try:
        if out.exists():
            shutil.rmtree(out)
        out.mkdir(parents=True)
        opts = task["options"]
        kw = {k: opts[k] for k in ("start_time", "record_interval", "record", "log_level", "step_multiples")
              if k in opts}
        kw.setdefault("log_level", "error")
        kw["write_csv"] = bool(opts.get("csv", True))
        if task.get("keep", "all") == "summary":
            kw["products"] = "summary"       # no map or trajectory that pruning would delete anyway
        if task["kind"] == "uav":
            scenario = _build_uav(task, out, used)
            params = {}
            seed = None            # the scenario's seed field (wind) is the run seed already
        else:
            scenario = Path(task["scenario"])
            from .spec import _tree_sha, file_sha256
            used["scenario_sha256"] = file_sha256(scenario) if scenario.is_file() else _tree_sha(scenario)
            params = dict(task["overrides"])
            seed = int(task["seed"])
            for k in ("stop_time", "step", "algorithm"):
                if k in opts:
                    kw[k] = opts[k]
        res = master.run(scenario, output=str(out), params=params, seed=seed, raise_on_error=False, **kw)
        meta = res.metadata
        oc = meta.get("outcome")
        rec["outcome"] = "completed" if oc == "completed" else ("interrupted" if oc == "interrupted" else "failed")
        if oc != "completed":
            rec["error"] = meta.get("error") or f"run ended with outcome {oc!r}"
        rec["scenario_sha256"] = meta.get("scenario_sha256")
        rec["fmus"] = {k: v.get("sha256") for k, v in (meta.get("fmus") or {}).items()}
        for k in ("steps", "step_size", "stop_time", "algorithm", "last_time", "failed_at"):
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
    if task["kind"] != "uav":
        rec["final"] = _final_values(out)
    _prune(out, task.get("keep", "all"))
    rec["wall_time_s"] = time.perf_counter() - t0
    rec["finished_at"] = _now()
    return rec
