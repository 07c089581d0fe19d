"""``run``: SSP in, fixed-step FMI orchestration, results out. The CLI is a thin layer over this."""
from __future__ import annotations

import json
import math
import os
import platform
import sys
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

from . import __version__
from .algorithms import get_algorithm
from .algorithms.ordering import algebraic_loops, gauss_seidel_order
from .errors import CosimError, ScenarioError
from .fmi.logsink import LogSink
from .monitors import MonitorContext, monitors_for
from .plan import add_overrides, build_plan
from .recorder import Recorder, select_variables
from .runtime import Runtime
from .ssp.archive import file_sha256, open_scenario
from .ssp.parser import read_ssd


@dataclass
class Result:
    output_dir: Path | None
    metadata: dict
    events: list = field(default_factory=list)
    _table: object = None

    @property
    def ok(self) -> bool:
        return self.metadata.get("outcome") == "completed"

    @property
    def frame(self):
        """The recorded time series as a pandas DataFrame (columns 'time' and 'component.variable')."""
        if self._table is not None:
            return self._table.to_pandas()
        import pandas as pd
        return pd.read_parquet(self.output_dir / "results.parquet")


def _steps(start: float, stop: float, h: float, what: str) -> int:
    exact = (stop - start) / h
    n = int(round(exact))
    if n < 1 or abs(n - exact) > 1e-9 * max(1.0, exact):
        raise CosimError(f"the interval {start:g}..{stop:g} is not a whole number of {what} steps of {h:g} "
                         f"({exact:.6g})", element="settings")
    return n


@dataclass
class Settings:
    start: float
    stop: float
    step: float
    steps: int
    algorithm: str
    record_every: int
    step_multiples: dict
    step_source: str


def resolve_settings(model, shown_as, *, start_time=None, stop_time=None, step=None, algorithm=None,
                     record_interval=None, step_multiples=None, fmus=None) -> Settings:
    s = model.settings
    start = start_time if start_time is not None else (model.start_time if model.start_time is not None else 0.0)
    stop = stop_time if stop_time is not None else model.stop_time
    if stop is None:
        raise ScenarioError("no stop time: the SSD has no DefaultExperiment stopTime and --stop-time was not given",
                            file=shown_as, element="DefaultExperiment")
    if stop <= start:
        raise ScenarioError(f"stop time {stop:g} is not after start time {start:g}", file=shown_as,
                            element="DefaultExperiment")
    source = "command line"
    if step is None:
        step, source = s.step_size, s.source
    if step is None and fmus:
        sizes = [f.md.defaultExperiment.stepSize for f in fmus.values()
                 if f.md.defaultExperiment is not None and f.md.defaultExperiment.stepSize]
        if sizes:
            step, source = min(float(x) for x in sizes), "smallest FMU DefaultExperiment stepSize"
    if step is None:
        raise ScenarioError("no step size: give --step or a master settings annotation", file=shown_as,
                            element="DefaultExperiment")
    if not (step > 0 and math.isfinite(step)):
        raise CosimError(f"step size must be positive, got {step}", element="--step")
    steps = _steps(start, stop, step, "master")
    interval = record_interval if record_interval is not None else s.record_interval
    record_every = 1
    if interval is not None:
        k = interval / step
        record_every = int(round(k))
        if record_every < 1 or abs(record_every - k) > 1e-9 * max(1.0, k):
            raise CosimError(f"record interval {interval:g} is not a whole multiple of the step {step:g}",
                             element="--record-interval")
    multiples = dict(s.step_multiples)
    multiples.update(step_multiples or {})
    alg = algorithm or s.algorithm or "jacobi"
    return Settings(start, stop, step, steps, alg, record_every, multiples, source or "command line")


def _seed_params(plan_vars, seed) -> dict:
    """A run seed is given to every component parameter named 'seed' (documented convention)."""
    out = {}
    for comp, vars_ in plan_vars.items():
        v = vars_.get("seed")
        if v is not None and v.causality == "parameter":
            out[f"{comp}.seed"] = int(seed)
    return out


def run(scenario, *, stop_time=None, start_time=None, step=None, algorithm=None, output="results",
        params: dict | None = None, record: list[str] | None = None, record_interval=None,
        log_level: str = "warning", seed: int | None = None, step_multiples: dict | None = None,
        inprocess: bool = True, progress: bool = False, raise_on_error: bool = True,
        write_csv: bool = True, products: str = "all") -> Result:
    """Run a scenario (.ssp archive, unpacked SSP folder or .ssd file) and return its recorded results.

    ``output=None`` keeps the results in memory only. ``products="summary"`` asks monitors for their summary
    files only (campaigns). On a failure the results recorded so far stay on
    disk, run.json says what happened, and a CosimError is raised (or returned in the Result's metadata
    with ``raise_on_error=False``).
    """
    wall0 = _time.perf_counter()
    scenario = Path(scenario)
    shown_as = str(scenario)
    src = open_scenario(scenario)
    meta: dict = {"scenario": shown_as, "package_version": __version__, "python": sys.version.split()[0],
                  "platform": platform.platform(), "seed": seed, "outcome": "error"}
    out_dir = Path(output) if output is not None else None
    rt = recorder = None
    events: list = []
    monitors = []
    log = None
    error: CosimError | None = None
    try:
        if scenario.is_file():
            meta["scenario_sha256"] = file_sha256(scenario)
        model = read_ssd(src.ssd_path, src.root, shown_root=src.shown_root)
        plan = build_plan(model, shown_as)
        user_params = dict(_seed_params(plan.variables, seed) if seed is not None else {})
        user_params.update(params or {})
        add_overrides(plan, user_params)
        st = resolve_settings(model, shown_as, start_time=start_time, stop_time=stop_time, step=step,
                              algorithm=algorithm, record_interval=record_interval, step_multiples=step_multiples,
                              fmus=plan.fmus)
        for name in st.step_multiples:
            if name not in plan.fmus:
                raise ScenarioError(f"step multiple given for unknown component {name!r}", file=shown_as,
                                    element="Settings")
        alg = get_algorithm(st.algorithm)
        meta.update({"algorithm": st.algorithm, "step_size": st.step, "step_size_source": st.step_source,
                     "start_time": st.start, "stop_time": st.stop, "steps": st.steps,
                     "record_interval": st.step * st.record_every, "step_multiples": st.step_multiples,
                     "parameters_overridden": {k: v for k, v in user_params.items()},
                     "fmus": {name: {"source": model.components[name].source, "sha256": f.sha256,
                                     "fmi_version": f.fmi_version,
                                     "kind": "CoSimulation" if f.md.coSimulation else "ModelExchange",
                                     "generation_tool": f.md.generationTool}
                              for name, f in plan.fmus.items()}})
        monitors = monitors_for(model, plan, shown_as)
        connected = []
        seen = set()
        for ln in plan.links:
            if ln.src.qualified not in seen:
                seen.add(ln.src.qualified)
                connected.append(ln.src)
        record = record or model.settings.record or None
        recorded = select_variables(plan, record, connected)
        if record and not recorded:
            raise CosimError(f"no variable matches the record patterns {record}", element="--record")
        observed = [plan.var(q) for m in monitors for q in m.required_variables()]
        if out_dir is not None:
            out_dir.mkdir(parents=True, exist_ok=True)
            log_file = open(out_dir / "fmu.log", "w", encoding="utf-8")
        else:
            log_file = None
        log = LogSink(log_level, file=log_file)
        loops = algebraic_loops(plan)
        meta["algebraic_loops"] = loops
        # loggingOn stays on below 'none': some exporters (pythonfmu) drop even error messages without it
        rt = Runtime(plan, observed, log, st.step_multiples, logging_on=(log_level != "none"), inprocess=inprocess,
                     sampled=recorded)
        recorder = Recorder(out_dir, recorded, rt, csv=write_csv)
        rt.instantiate(st.start, st.stop)
        rt.apply_start_values(st.start)
        init_order = gauss_seidel_order(plan, rt.names).order
        loop_desc = "; ".join(" -> ".join(lp) for lp in loops) or "(none declared)"
        rt.initialize(st.start, init_order, bool(loops), loop_desc)
        meta["algorithm_info"] = alg.prepare(rt, plan, st.step)
        ctx = MonitorContext(rt, events)
        for m in monitors:
            m.attach(ctx, st.start)
        recorder.sample(st.start)
        meta["last_time"] = st.start
        _loop(alg, rt, recorder, monitors, st, meta, progress)
        meta["outcome"] = "completed"
    except CosimError as exc:
        error = exc
        meta["error"] = str(exc)
        if exc.time is not None:
            meta["failed_at"] = exc.time
    except KeyboardInterrupt:
        meta["outcome"] = "interrupted"
        error = CosimError("interrupted by the user", time=meta.get("last_time"))
        meta["error"] = str(error)
    finally:
        if recorder is not None:
            recorder.close()
            meta["rows_recorded"] = recorder.rows_written
        if rt is not None:
            rt.terminate()
        for m in monitors:
            m.products = products
            try:
                meta.setdefault("monitors", {})[m.annotation_type] = m.finish(out_dir, meta["outcome"])
            except CosimError as exc:  # a monitor's report must not hide the run's own outcome
                meta.setdefault("monitor_errors", []).append(str(exc))
        if log is not None:
            meta["fmu_log_counts"] = {k: v for k, v in log.counts.items() if v}
            log.close()
        src.close()
        meta["wall_time_s"] = _time.perf_counter() - wall0
        if out_dir is not None and out_dir.exists():
            if events:
                _write_events(out_dir, events)
            tmp = out_dir / "run.json.tmp"
            tmp.write_text(json.dumps(meta, indent=2, default=_json_default))
            os.replace(tmp, out_dir / "run.json")
    result = Result(out_dir, meta, events, recorder.memory_table() if recorder is not None and out_dir is None else None)
    if error is not None:
        error.result = result
        if raise_on_error:
            raise error
    return result


def _loop(alg, rt, recorder, monitors, st, meta, progress):
    start, h, steps, every = st.start, st.step, st.steps, st.record_every
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=steps, unit="step", mininterval=0.5, leave=False)
    step = alg.step
    sample, read_samples = recorder.sample, rt.read_samples
    try:
        for n in range(steps):
            t = start + n * h          # integer step counting: no drift from accumulated additions
            step(n, t)
            t1 = start + (n + 1) * h
            meta["last_time"] = t1
            for m in monitors:
                m.after_step(n, t, t1)
            if (n + 1) % every == 0 or n + 1 == steps or rt.stop_reason is not None:
                read_samples(t1)
                sample(t1)
            if rt.stop_reason is not None:
                meta["ended_early"] = {"time": t1, "reason": rt.stop_reason}
                meta["steps_done"] = n + 1
                break
            if bar is not None and (n & 255) == 255:
                bar.update(256)
        else:
            meta["steps_done"] = steps
    finally:
        if bar is not None:
            bar.close()


def _write_events(out_dir: Path, events: list) -> None:
    import pandas as pd
    df = pd.DataFrame(events)
    df.to_csv(out_dir / "events.csv", index=False)


def _json_default(o):
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
    except ImportError:
        pass
    if isinstance(o, Path):
        return str(o)
    return str(o)
