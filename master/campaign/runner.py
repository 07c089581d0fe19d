"""``run_campaign``: expand a campaign, run what is missing, keep every finished run, rebuild the table.

Layout of a campaign folder (default ``results/<campaign name>``)::

    campaign.yaml        copy of the campaign file of the last invocation
    campaign.json        the resolved campaign: run order, ids, parameters, seeds, input fingerprints
    runs/<run_id>.json   one record per finished run (written atomically as the run finishes)
    runs/<run_id>/       the run's own output folder (results, map, summary; see ``keep``)
    results.parquet      the tidy table (master.campaign.table), rebuilt after every invocation
    results.csv          the same table as CSV
    report/              written by ``cosim-master report``

Rerunning the same command skips every run that has a record whose input fingerprint (scenario file
and FMU hashes, result-relevant run options, seed) matches; a record that no longer matches is stale:
the run runs again and the describe() text says why.  A failed run is a finished run (its record says
why it failed); ``retry_failed=True`` runs failed runs again.
"""
from __future__ import annotations

import json
import os
import shutil
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import CosimError
from .spec import RESULT_OPTIONS, Campaign, RunSpec, load_campaign
from .table import read_record, write_table

__all__ = ["run_campaign", "CampaignSummary", "make_task", "plan_campaign"]


@dataclass
class CampaignSummary:
    name: str
    output: Path
    total: int = 0
    completed: int = 0
    failed: int = 0
    pending: int = 0
    ran_now: int = 0
    failed_now: int = 0
    skipped: int = 0
    stale: int = 0
    stale_reasons: dict = field(default_factory=dict)
    unreadable: int = 0
    foreign_records: int = 0
    changed_during_run: int = 0
    interrupted: str | bool = False     # "SIGINT" (Ctrl-C) or "SIGTERM" when one stopped it
    wall_time_s: float = 0.0
    run_time_s: float = 0.0
    workers: int = 0
    scheduler: str | None = None
    worker_restarts: int = 0
    failures: list = field(default_factory=list)    # (run_id, params, error) of all failed runs
    table: Path | None = None

    @property
    def complete(self) -> bool:
        return not self.interrupted and self.pending == 0

    @property
    def ok(self) -> bool:
        """True when every run of the campaign has a record and none of them failed."""
        return self.complete and self.failed == 0

    def describe(self) -> str:
        where = f"Dask scheduler {self.scheduler}" if self.scheduler else \
            f"{self.workers} local worker process{'es' if self.workers != 1 else ''}"
        parts = [f"Campaign {self.name}: {self.total} runs, {self.completed} completed, {self.failed} failed, "
                 f"{self.pending} not run yet."]
        if self.ran_now:
            rate = self.ran_now / self.wall_time_s * 60 if self.wall_time_s > 0 else float("nan")
            per_core = rate / max(1, self.workers) if not self.scheduler else None
            parts.append(f"This invocation ran {self.ran_now} run{'s' if self.ran_now != 1 else ''} "
                         f"({self.failed_now} failed) in {self.wall_time_s:.1f} s on {where}: {rate:.1f} runs/min"
                         + (f", {per_core:.1f} runs/min per worker" if per_core is not None else "")
                         + (f"; {self.worker_restarts} worker(s) replaced after a crash or timeout"
                            if self.worker_restarts else "") + ".")
        else:
            parts.append("This invocation ran nothing.")
        if self.skipped:
            parts.append(f"Skipped {self.skipped} run{'s' if self.skipped != 1 else ''} already finished.")
        if self.stale:
            why = "; ".join(f"{k}: {v}" for k, v in sorted(self.stale_reasons.items()))
            parts.append(f"{self.stale} earlier record{'s were' if self.stale != 1 else ' was'} stale ({why}): "
                         "left out of the table and run again.")
        if self.changed_during_run:
            parts.append(f"{self.changed_during_run} run(s) used a scenario file or FMU that changed while the campaign "
                         "was running: their records are marked stale and they run again next time.")
        if self.unreadable:
            parts.append(f"{self.unreadable} unreadable record(s) were ignored and their runs queued again.")
        if self.foreign_records:
            parts.append(f"{self.foreign_records} record(s) in runs/ do not belong to this campaign definition "
                         "and are left out of the table.")
        if self.failures:
            shown = "; ".join(f"{rid} {json.dumps(p, sort_keys=True)}: {e}" for rid, p, e in self.failures[:3])
            more = f" (and {len(self.failures) - 3} more)" if len(self.failures) > 3 else ""
            parts.append(f"Failed: {shown}{more}.")
        if self.interrupted:
            parts.append("Interrupted: only complete runs were recorded; rerun the same command to resume.")
        elif self.pending:
            parts.append("Rerun the same command to run the rest.")
        if self.table is not None:
            parts.append(f"Table: {self.table}.")
        return " ".join(parts)


# --------------------------------------------------------------------------------------------- tasks
def make_task(camp: Campaign, r: RunSpec, out: Path, inputs_sha256: str | None = None) -> dict:
    """The plain-data task a worker needs (picklable for process pipes and Dask); ``inputs_sha256``: the run's
    fingerprint when the caller has it already (it is recomputed from the inputs otherwise)."""
    return {"campaign": camp.name, "run_id": r.run_id, "index": r.index, "params": r.params, "rep": r.rep,
            "seed": r.seed, "campaign_seed": camp.seed, "kind": camp.kind, "scenario": str(r.scenario),
            "options": r.options, "overrides": r.overrides, "inputs": r.inputs,
            "inputs_sha256": inputs_sha256 or r.inputs_sha256,
            "out_dir": str(out / "runs" / r.run_id), "campaign_dir": str(out), "keep": camp.keep}


def _atomic_write(path: Path, text: str):
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _stale_reasons(old: dict, new: dict) -> list[str]:
    out = []
    if old.get("scenario_sha256") != new.get("scenario_sha256") or old.get("scenario") != new.get("scenario"):
        out.append(f"scenario file {new.get('scenario')} changed")
    of, nf = old.get("fmus") or {}, new.get("fmus") or {}
    for k in sorted(set(of) | set(nf)):
        if of.get(k) != nf.get(k):
            out.append(f"FMU {k} changed")
    if old.get("options") != new.get("options"):
        out.append("run options changed")
    def params(d):   # a scenario kind may carry step/stop_time/algorithm in its overrides too
        return {k: v for k, v in (d.get("overrides") or {}).items() if k not in RESULT_OPTIONS}
    if params(old) != params(new):
        out.append("parameters changed")
    if old.get("seed") != new.get("seed"):
        out.append("seed changed")
    if old.get("code_sha256") != new.get("code_sha256"):
        out.append("cosim-master's code changed")
    return out or ["inputs changed"]


def _changed_inputs(expected: dict, used: dict | None) -> list[str]:
    """What the worker actually used that differs from the inputs hashed when the campaign started."""
    if not used:
        return []
    out = []
    if used.get("scenario_sha256") and used["scenario_sha256"] != expected.get("scenario_sha256"):
        out.append(f"scenario file {expected.get('scenario')} changed")
    known = set((expected.get("fmus") or {}).values())
    if any(h not in known for h in used.get("fmus") or []):
        out.append("an FMU changed")
    if used.get("code_sha256") and expected.get("code_sha256") and used["code_sha256"] != expected["code_sha256"]:
        out.append("cosim-master's code differs where the run ran")
    return out


def plan_campaign(camp: Campaign, out: Path, retry_failed: bool = False, fingerprints: dict | None = None):
    """Sort the campaign's runs into done / to-run by their records; returns (done, todo, summary).
    ``fingerprints``: run_id -> inputs_sha256, when the caller has them (else each is computed from the inputs)."""
    s = CampaignSummary(camp.name, out, total=len(camp.runs))
    runs_dir = out / "runs"
    done, todo = [], []
    reasons: Counter = Counter()
    for r in camp.runs:
        p = runs_dir / f"{r.run_id}.json"
        if not p.exists():
            todo.append(r)
            continue
        rec = read_record(p)
        if rec is None:
            s.unreadable += 1
            todo.append(r)
            continue
        if rec.get("inputs_sha256") != (fingerprints[r.run_id] if fingerprints else r.inputs_sha256):
            s.stale += 1
            for why in rec.get("inputs_changed") or _stale_reasons(rec.get("inputs") or {}, r.inputs):
                reasons[why if not rec.get("inputs_changed") else f"{why} during the run"] += 1
            todo.append(r)
            continue
        if rec.get("outcome") == "failed" and retry_failed:
            todo.append(r)
            continue
        done.append((r, rec))
    s.stale_reasons = dict(reasons)
    ids = {r.run_id for r in camp.runs}
    s.foreign_records = sum(1 for p in runs_dir.glob("*.json") if p.stem not in ids)
    return done, todo, s


def table_records(done: list) -> list[dict]:
    """The records of the table among ``plan_campaign``'s done runs: what ``table.load_records`` would read from
    disk again (current, finished, in run order)."""
    return [rec for _, rec in done if rec.get("outcome") in ("completed", "failed")]


class _Lock:
    """One invocation per campaign folder at a time (flock on .lock)."""

    def __init__(self, folder: Path):
        self.path = folder / ".lock"
        self.fh = None

    def __enter__(self):
        import fcntl
        self.fh = open(self.path, "a+")
        try:
            fcntl.flock(self.fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.fh.close()
            raise CosimError("another campaign invocation is running in this folder", file=str(self.path.parent))
        return self

    def __exit__(self, *exc):
        import fcntl
        fcntl.flock(self.fh.fileno(), fcntl.LOCK_UN)
        self.fh.close()


def _default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # pragma: no cover - not Linux
        return os.cpu_count() or 1


def run_campaign(path, output=None, workers=None, scheduler=None, progress=True, *, max_runs: int | None = None,
                 retry_failed: bool = False, run_filter=None) -> CampaignSummary:
    """Run the campaign file ``path`` (see docs/campaigns.md); returns a :class:`CampaignSummary`.

    ``output``: campaign folder (default ``results/<name>``); ``workers``: local worker processes (default:
    every core); ``scheduler``: address of a Dask distributed scheduler (the runs go there instead);
    ``max_runs``: run at most this many of the missing runs (the rest stay for the next invocation);
    ``retry_failed``: run failed runs again; ``run_filter``: a predicate on :class:`RunSpec` -- only the
    missing runs it accepts run now (the others stay pending).
    """
    t_start = time.perf_counter()
    with _sigterm_as_interrupt():
        return _run_campaign_with_pool(path, output, workers, scheduler, progress, max_runs, retry_failed,
                                       run_filter, t_start)


def _sigterm_as_interrupt():
    """SIGTERM (``timeout``, systemd, ``kill``) stops a campaign as Ctrl-C does: runs in flight are dropped, the
    table is written and the summary says so; by default it killed the process with no word."""
    import contextlib
    import signal
    import threading

    from ..errors import Terminated

    @contextlib.contextmanager
    def held():
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def terminated(signum, frame):
            raise Terminated()
        previous = signal.signal(signal.SIGTERM, terminated)
        try:
            yield
        finally:
            signal.signal(signal.SIGTERM, previous)
    return held()


def _run_campaign_with_pool(path, output, workers, scheduler, progress, max_runs, retry_failed, run_filter,
                            t_start) -> CampaignSummary:
    pool = None
    if not scheduler:
        # the local workers start now: their interpreters and imports take a core that would otherwise wait
        # while the campaign is loaded and planned here
        from .pool import WorkerPool
        pool = WorkerPool(int(workers) if workers else _default_workers())
        pool.start()
    try:
        s = _run_campaign(path, output, workers, scheduler, progress, max_runs, retry_failed, run_filter, pool)
    finally:
        if pool is not None:
            pool.close()
    s.run_time_s = time.perf_counter() - t_start
    return s


def _run_campaign(path, output, workers, scheduler, progress, max_runs, retry_failed, run_filter,
                  pool) -> CampaignSummary:
    camp = load_campaign(path)
    out = Path(output) if output is not None else Path("results") / camp.name
    out = out.resolve()
    _refuse_another_campaign(out, camp.name)
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
        with open(out / ".lock", "a+"):     # a read-only existing folder: said here, in one line
            pass
    except OSError as exc:
        raise CosimError(f"cannot write into the campaign folder: {exc.strerror or exc}", file=str(out),
                         element="--output") from None
    with _Lock(out):
        manifest = camp.manifest()
        # a run's fingerprint is a hash of its canonical inputs: computed once here, not for every plan and task
        fingerprints = {r["run_id"]: r["inputs_sha256"] for r in manifest["runs"]}
        _atomic_write(out / "campaign.json", json.dumps(manifest, indent=1))
        _atomic_write(out / "campaign.yaml", camp.text)
        for p in (out / "runs").glob(".*.tmp*"):
            p.unlink(missing_ok=True)
        done, todo, s = plan_campaign(camp, out, retry_failed, fingerprints)
        s.skipped = len(done)
        if run_filter is not None:
            todo = [r for r in todo if run_filter(r)]
        if max_runs is not None:
            todo = todo[:max(0, int(max_runs))]
        tasks = [make_task(camp, r, out, fingerprints[r.run_id]) for r in todo]
        n_workers = 0 if scheduler else max(1, min(int(workers) if workers else _default_workers(), max(1, len(tasks))))
        s.workers, s.scheduler = n_workers, scheduler
        bar = None
        if progress and tasks:
            from tqdm import tqdm
            # redrawn at most twice a second: each redraw is parent CPU taken from the workers' cores
            bar = tqdm(total=len(tasks), unit="run", desc=camp.name, dynamic_ncols=True, smoothing=0.05,
                       mininterval=0.5)
            bar.set_postfix(failed=0)
        counts = Counter()

        by_id = {t["run_id"]: t for t in tasks}
        warm_table = []

        def on_result(rec: dict):
            if not warm_table:
                warm_table.append(_import_table_modules_meanwhile())
            if rec.get("outcome") not in ("completed", "failed"):
                counts["not_recorded"] += 1     # interrupted inside the run: not a finished run
                return
            changed = _changed_inputs(by_id[rec["run_id"]]["inputs"], rec.get("used"))
            if changed:                         # an input changed since the campaign hashed it: never current
                rec["inputs_sha256"] = "changed-during-run"
                rec["inputs_changed"] = changed
                s.changed_during_run += 1
            _atomic_write(out / "runs" / f"{rec['run_id']}.json", json.dumps(rec, indent=1, default=str))
            counts[rec["outcome"]] += 1
            if bar is not None:
                if rec["outcome"] == "failed":     # set_postfix redraws the bar: only when the count changes
                    bar.set_postfix(failed=counts["failed"], refresh=False)
                bar.update(1)

        t_run = time.perf_counter()
        try:
            if tasks:
                if scheduler:
                    _run_dask(scheduler, tasks, on_result)
                else:
                    pool.n, pool.timeout = n_workers, camp.options.get("timeout")
                    try:
                        pool.run(tasks, on_result, wait=False)     # they exit while the table is written
                    finally:
                        s.worker_restarts = pool.crashes
        except KeyboardInterrupt as exc:
            s.interrupted = _by(exc)
        finally:
            if bar is not None:
                bar.close()
        s.wall_time_s = time.perf_counter() - t_run
        s.ran_now = counts["completed"] + counts["failed"]
        s.failed_now = counts["failed"]
        # final state from disk (the records are the truth)
        done2, todo2, _ = plan_campaign(camp, out, False, fingerprints)
        s.completed = sum(1 for _, rec in done2 if rec.get("outcome") == "completed")
        s.failed = sum(1 for _, rec in done2 if rec.get("outcome") == "failed")
        s.pending = len(todo2)
        s.failures = [(r.run_id, r.params, rec.get("error")) for r, rec in done2 if rec.get("outcome") == "failed"]
        try:
            s.table = write_table(out, manifest, table_records(done2))
        except KeyboardInterrupt as exc:
            s.interrupted = _by(exc)
        _cleanup_orphans(out, camp)
    return s


def _refuse_another_campaign(out: Path, name: str) -> None:
    """A folder holding another campaign (by name) is refused before anything is written there: its
    campaign.yaml, table and report were silently replaced by the new campaign's. The same campaign, edited or
    not, resumes (its changed runs are stale and run again)."""
    manifest = out / "campaign.json"
    if not manifest.is_file():
        return
    try:
        held = json.loads(manifest.read_text(encoding="utf-8")).get("name")
    except (OSError, ValueError, AttributeError):
        held = None
    if held != name:
        what = f"the campaign {held!r}" if isinstance(held, str) else "an unreadable campaign.json"
        raise CosimError(f"the folder holds {what}, not {name!r}: give another -o DIR (or remove the folder to "
                         "start anew)", file=str(out), element="--output")


def _by(exc: KeyboardInterrupt) -> str:
    from ..errors import Terminated
    return "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"


def _import_table_modules_meanwhile():
    """Import what write_table needs (pandas, pyarrow.parquet: ~0.3 s) in a thread while the runs go on: after
    the last run every core waits for the table.  Started with the first record, once the workers' own start-up
    is over.  The import lock makes write_table wait for an import still in progress."""
    import threading

    def imports():
        try:
            import pandas  # noqa: F401
            import pyarrow.parquet  # noqa: F401
        except Exception:   # noqa: BLE001 - write_table will report it
            pass
    t = threading.Thread(target=imports, name="cosim-campaign-table-imports", daemon=True)
    t.start()
    return t


def _cleanup_orphans(out: Path, camp: Campaign):
    """Remove run folders left by runs that were interrupted (no record): they would confuse a reader."""
    runs_dir = out / "runs"
    ids = {r.run_id for r in camp.runs}
    for d in runs_dir.iterdir():
        if d.is_dir() and d.name in ids and not (runs_dir / f"{d.name}.json").exists():
            shutil.rmtree(d, ignore_errors=True)


# --------------------------------------------------------------------------------------------- Dask
#: how often a run is submitted again after Dask reported its worker killed (see _run_dask)
DASK_KILLED_RETRIES = 2


def _run_dask(scheduler, tasks: list[dict], on_result):
    """Submit every task to a Dask distributed scheduler; records come back as the futures finish.

    The runs' own folders are written by the Dask workers (a shared filesystem is assumed for them);
    the records travel back with the results and are written here.  Each worker thread runs its tasks in a
    child process of its own (``isolated.run_isolated``), so a crashing FMU or the run ``timeout`` costs the
    run only, with the same failure records as the local pool.
    """
    import uuid

    from distributed import Client, as_completed

    from .execute import failure_record
    from .isolated import run_isolated
    client = scheduler if hasattr(scheduler, "submit") else Client(scheduler, timeout="30s")
    token = uuid.uuid4().hex[:8]
    futures = {}
    attempts: dict[str, int] = {}

    def submit(t):
        n = attempts[t["run_id"]] = attempts.get(t["run_id"], 0) + 1
        # each run in a child process of the Dask worker: a crash or a timeout is the run's failure record
        f = client.submit(run_isolated, t, key=f"cosim-run-{t['run_id']}-{token}-{n}", pure=False)
        futures[f] = t
        return f

    try:
        pending = as_completed([submit(t) for t in tasks])
        for f in pending:
            t = futures.pop(f)
            try:
                rec = f.result()
            except Exception as exc:   # noqa: BLE001 - the run failed outside execute_run
                if type(exc).__name__ == "KilledWorker" and attempts[t["run_id"]] <= DASK_KILLED_RETRIES:
                    # Dask blames every run assigned to a worker that died, queued ones too: only a run
                    # that kills a worker again when run again is the culprit
                    pending.add(submit(t))
                    continue
                rec = failure_record(t, _dask_reason(exc, attempts[t["run_id"]]))
            on_result(rec)
    finally:
        if futures:
            try:
                client.cancel(list(futures))
            except Exception:   # noqa: BLE001
                pass
        if client is not scheduler:
            client.close()


def _dask_reason(exc: Exception, attempts: int = 1) -> str:
    name = type(exc).__name__
    if name == "KilledWorker":
        return (f"worker process died (Dask KilledWorker, {attempts} attempt(s): every worker that tried this run "
                "died while running it, e.g. an FMU crashed the process)")
    return f"{name}: {exc}"
