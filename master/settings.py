"""Master settings of a run: command line (or API) over the SSD settings annotation over the FMUs' default
experiments."""
from __future__ import annotations

import math
from dataclasses import dataclass

from .errors import CosimError, ScenarioError


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
    for value, what in ((start_time, "--start-time"), (stop_time, "--stop-time")):
        if value is not None and not math.isfinite(value):
            raise CosimError(f"must be a finite time in seconds, got {value}", element=what)
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
        if not (math.isfinite(interval) and interval > 0):
            raise CosimError(f"record interval must be positive, got {interval}", element="--record-interval")
        k = interval / step
        record_every = int(round(k))
        if record_every < 1 or abs(record_every - k) > 1e-9 * max(1.0, k):
            raise CosimError(f"record interval {interval:g} is not a whole multiple of the step {step:g}",
                             element="--record-interval")
    multiples = dict(s.step_multiples)
    multiples.update(step_multiples or {})
    for name, k in multiples.items():
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise CosimError(f"step multiple of {name} must be a positive integer, got {k!r}",
                             element="--step-multiple")
    alg = algorithm or s.algorithm or "jacobi"
    return Settings(start, stop, step, steps, alg, record_every, multiples, source or "command line")
