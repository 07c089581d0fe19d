"""Master settings of a run: command line (or API) over the SSD (its DefaultExperiment and settings
annotations) over the FMUs' default experiments, over fixed defaults. run.json says where each came from.

The algorithm an SSD names is checked against the algorithm registry here, not where the SSD is read: resolving
the settings sits above the algorithms (it names one), reading an SSD below them."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .algorithms import ALGORITHMS
from .errors import CosimError, ScenarioError

#: without any step size given, a run takes this many steps (fmpy's default output interval is the same)
DEFAULT_STEPS = 500


@dataclass
class Settings:
    start: float
    stop: float
    step: float
    steps: int                  # master steps, the last one possibly shorter (``last_step``)
    algorithm: str
    record_every: int
    step_multiples: dict
    step_source: str
    last_step: float | None = None       # the length of a shorter final step, when the interval is not whole
    tolerance: float | None = None       # given to every FMU; None: each FMU's own default experiment tolerance
    sources: dict = field(default_factory=dict)   # setting -> where it came from


def _fmu_default(fmus, attr: str):
    """The FMUs' default experiment ``attr``: their common value, else the smallest (with how it was chosen)."""
    values = sorted({float(getattr(f.md.defaultExperiment, attr)) for f in (fmus or {}).values()
                     if f.md.defaultExperiment is not None and getattr(f.md.defaultExperiment, attr, None)
                     not in (None, "")})
    if not values:
        return None, None
    return values[0], ("FMU DefaultExperiment" if len(values) == 1 else "smallest FMU DefaultExperiment")


def _time_setting(given, ssd_value, fmus, attr: str):
    """(value, source): the command line's, else the SSD's, else the FMUs' default experiment's."""
    if given is not None:
        return given, "command line"
    if ssd_value is not None:
        return ssd_value, "SSD DefaultExperiment"
    return _fmu_default(fmus, attr)


def _finite(value, what):
    if value is not None and not math.isfinite(value):
        raise CosimError(f"must be a finite time in seconds, got {value}", element=what)


def count_steps(start: float, stop: float, h: float, allow_partial: bool) -> tuple[int, float | None]:
    """(steps, last step length or None): a final partial step when the interval is not a whole number of
    steps (and that is allowed), the remainder below 1e-9 steps counting as whole."""
    exact = (stop - start) / h
    n = int(round(exact))
    if n >= 1 and abs(n - exact) <= 1e-9 * max(1.0, exact):
        return n, None
    whole = int(math.floor(exact))
    if not allow_partial:
        raise CosimError(f"the interval {start:g}..{stop:g} is not a whole number of master steps of {h:g} "
                         f"({exact:.6g}), which components with a step multiple need", element="settings")
    return whole + 1, stop - (start + whole * h)


def resolve_settings(model, shown_as, *, start_time=None, stop_time=None, step=None, algorithm=None,
                     record_interval=None, step_multiples=None, fmus=None, tolerance=None) -> Settings:
    s = model.settings
    if s.algorithm is not None and s.algorithm not in ALGORITHMS:
        raise ScenarioError(f"unknown algorithm {s.algorithm!r} (known: {', '.join(ALGORITHMS.names())})",
                            file=shown_as, element="Settings", line=s.algorithm_line)
    sources = {}
    _finite(start_time, "--start-time")
    _finite(stop_time, "--stop-time")
    start, sources["start"] = _time_setting(start_time, model.start_time, fmus, "startTime")
    if start is None:
        start, sources["start"] = 0.0, "default"
    stop, sources["stop"] = _time_setting(stop_time, model.stop_time, fmus, "stopTime")
    if stop is None:
        raise ScenarioError("no stop time: neither --stop-time, the SSD's DefaultExperiment nor an FMU's default "
                            "experiment gives one", file=shown_as, element="DefaultExperiment")
    if stop <= start:
        raise ScenarioError(f"stop time {stop:g} is not after start time {start:g}", file=shown_as,
                            element="DefaultExperiment")
    source = "command line"
    if step is None:
        step, source = s.step_size, s.source
    if step is None:
        step, source = _fmu_default(fmus, "stepSize")
        if source:
            source += " stepSize"
    if step is None:
        step, source = (stop - start) / DEFAULT_STEPS, f"default: (stop - start) / {DEFAULT_STEPS}"
    if not (step > 0 and math.isfinite(step)):
        raise CosimError(f"step size must be positive, got {step}", element="--step")
    multiples = dict(s.step_multiples)
    multiples.update(step_multiples or {})
    for name, k in multiples.items():
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise CosimError(f"step multiple of {name} must be a positive integer, got {k!r}",
                             element="--step-multiple")
    steps, last = count_steps(start, stop, step, allow_partial=not any(k > 1 for k in multiples.values()))
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
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        raise CosimError(f"tolerance must be positive, got {tolerance}", element="--tolerance")
    sources["tolerance"] = "command line" if tolerance is not None else "each FMU's DefaultExperiment"
    alg = algorithm or s.algorithm or "jacobi"
    return Settings(start, stop, step, steps, alg, record_every, multiples, source or "command line", last,
                    tolerance, sources)
