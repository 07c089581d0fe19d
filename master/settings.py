"""Master settings of a run: command line (or API) over the SSD (its DefaultExperiment and settings
annotations) over the FMUs' default experiments, over fixed defaults. run.json says where each came from.

The algorithm an SSD names is checked against the algorithm registry here, not where the SSD is read: resolving
the settings sits above the algorithms (it names one), reading an SSD below them."""
from __future__ import annotations

import math

from .algorithms import ALGORITHMS
from .errors import CosimError, ScenarioError
from .records import Record

#: without any step size given, a run takes this many steps (fmpy's default output interval is the same)
DEFAULT_STEPS = 500


class Settings(Record):
    """The resolved settings of a run. A plain class, not a dataclass: Python 3.11 compiles a dataclass's methods
    from source in every process, a cost every run's start-up paid (``master.records`` says more)."""
    def __init__(self, start: float, stop: float, step: float, steps: int, algorithm: str, record_every: int,
                 step_multiples: dict, step_source: str, last_step: float | None = None,
                 tolerance: float | None = None, sources: dict | None = None, final_steps: dict | None = None):
        self.start, self.stop, self.step = start, stop, step
        self.steps = steps                  # master steps, the last one possibly shorter (``last_step``)
        self.algorithm = algorithm
        self.record_every = record_every
        self.step_multiples = step_multiples
        self.step_source = step_source
        self.last_step = last_step          # the length of a shorter final step, when the interval is not whole
        self.tolerance = tolerance          # given to every FMU; None: each FMU's own default experiment tolerance
        self.sources = {} if sources is None else sources    # setting -> where it came from
        #: component on a step multiple -> (n0, length): its last macro step starts at master step n0 and is
        #: ``length`` long, so that it ends at the stop time (``final_macro_steps``: only where k h would not end
        #: there)
        self.final_steps = {} if final_steps is None else final_steps


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


#: more master steps than any run can take (31 years at a microsecond a step), and beyond 2**53 the step count
#: t = start + n h would no longer be exact: refused in one line instead of an OverflowError or a run for ever
MAX_STEPS = 10**15


def count_steps(start: float, stop: float, h: float, allow_partial: bool) -> tuple[int, float | None]:
    """(steps, last step length or None): a final partial step when the interval is not a whole number of
    steps (and that is allowed), the remainder below 1e-9 steps counting as whole."""
    exact = (stop - start) / h
    if not exact <= MAX_STEPS:        # also inf: (1e308 - -1e308) / h
        raise CosimError(f"{start:g}..{stop:g} s in steps of {h:g} s is {exact:.3g} steps, more than any run can "
                         f"take (at most {MAX_STEPS:.0e})", element="settings")
    n = int(round(exact))
    if n >= 1 and abs(n - exact) <= 1e-9 * max(1.0, exact):
        return n, _exact_last_step(start, stop, h, n)
    whole = int(math.floor(exact))
    if not allow_partial:
        raise CosimError(f"the interval {start:g}..{stop:g} is not a whole number of master steps of {h:g} "
                         f"({exact:.6g}), which components with a step multiple need", element="settings")
    return whole + 1, stop - (start + whole * h)


def _exact_last_step(start: float, stop: float, h: float, n: int) -> float | None:
    """None when the n-th step of a whole interval ends exactly at ``stop``: both as the master counts it
    (start + n h) and as an FMU adds its doStep's arguments (start + (n - 1) h, plus h); else the length that
    makes it end there. With n h rounding past the stop time (0.1 * 500 = 50.00000000000001), an FMU would be
    asked to step past the stop time given to it at setup, which FMI 1.0 FMUs refuse (Ecos's dp_ship)."""
    last = start + (n - 1) * h
    if start + n * h == stop and last + h == stop:
        return None
    return stop - last


def final_macro_steps(start: float, stop: float, h: float, steps: int, multiples: dict) -> dict:
    """Per component on a step multiple k > 1 whose last macro step, started at n0 = k floor((steps - 1) / k), would
    not end exactly at ``stop`` as the FMU adds its doStep's arguments (start + n0 h, plus k h): (n0, stop - (start +
    n0 h)). Such a step ends 1 ulp past the stop time (k = 2, 0.1 s to 50 s: 49.800000000000004 + 0.2), or, where
    the interval is no whole number of macro steps, up to (k - 1) h past it; FMI 2.0 forbids a step past the stop
    time given to fmi2SetupExperiment. The last macro step is then shortened (or lengthened by an ulp) to end
    there, and its outputs are published at the last master step."""
    final = {}
    for name, k in multiples.items():
        if k <= 1:
            continue
        n0 = (steps - 1) // k * k
        t0 = start + n0 * h
        if n0 + k == steps and t0 + k * h == stop:
            continue
        final[name] = (n0, stop - t0)
    return final


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
        # named as where each came from: a --stop-time -5 is the command line's mistake, not the SSD's
        both = f"stop time {stop:g} ({sources['stop']}) is not after start time {start:g} ({sources['start']})"
        if sources["stop"] == "command line":
            raise CosimError(both, element="--stop-time")
        if sources["start"] == "command line":
            raise CosimError(both, element="--start-time")
        raise ScenarioError(both, file=shown_as, element="DefaultExperiment")
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
        raise CosimError(f"step size must be a positive finite number of seconds, got {step}", element="--step")
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
            raise CosimError(f"record interval must be a positive finite number of seconds, got {interval}",
                             element="--record-interval")
        k = interval / step
        record_every = int(round(k))
        if record_every < 1 or abs(record_every - k) > 1e-9 * max(1.0, k):
            # say which was given: a --step 0.3 against the SSD's recordInterval is not a --record-interval mistake
            why = (f"record interval {interval:g} ({'command line' if record_interval is not None else 'SSD'}) "
                   f"is not a whole multiple of the step {step:g} ({source or 'command line'})")
            if record_interval is not None:
                raise CosimError(why, element="--record-interval")
            raise ScenarioError(why + "; give a --record-interval that is", file=shown_as,
                                element="Settings recordInterval")
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        raise CosimError(f"tolerance must be positive, got {tolerance}", element="--tolerance")
    sources["tolerance"] = "command line" if tolerance is not None else "each FMU's DefaultExperiment"
    alg = algorithm or s.algorithm or "jacobi"
    return Settings(start, stop, step, steps, alg, record_every, multiples, source or "command line", last,
                    tolerance, sources, final_macro_steps(start, stop, step, steps, multiples))
