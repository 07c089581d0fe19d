"""A study's table: every run's error against the reference per signal, and the observed order.

``error_max`` = max over the run's recorded times of |y - y_ref|, ``error_rms`` = the root mean square of the
same differences. ``observed_order`` of a row = the log-log slope of ``error_max`` between its step and the
next larger step of the same algorithm, settings and signal: log(e(H) / e(h)) / log(H / h). It is left empty

- for the largest step, and where an error is missing;
- for variable-step algorithms (adaptive, ecco): their ``step`` is the master step the record grid sits on,
  not the step they take, so a slope against it means nothing (sweep their tolerance instead);
- for a run that diverged (below);
- where either error is at round-off level: at most ``ROUNDOFF`` times the signal's largest reference
  magnitude (1e-12: about 4500 machine epsilons; below it the error is the scatter of floating-point sums,
  not a truncation error, and its slope is noise).

A run **diverged** when any of its errors is not finite or larger than ``DIVERGED`` times the signal's largest
reference magnitude (10: a coupled solution ten times off the scale of the true one has left it; no
co-simulation of a stable system gets there by truncation error).
"""
from __future__ import annotations

import math

import numpy as np

ROUNDOFF = 1e-12
DIVERGED = 10.0

#: the leading columns of study.csv; the settings swept as axes come after ``step``
COLUMNS = ["algorithm", "extrapolation", "step", "signal", "error_max", "error_rms", "fmu_calls", "wall_s",
           "observed_order", "outcome", "steps", "iterations", "rejected", "reference", "reference_error",
           "reference_magnitude"]

#: what a row's grid point is made of besides its settings axes
GRID = ("algorithm", "extrapolation", "step")


def run_errors(frame, reference, signals: list[str]) -> dict[str, tuple[float, float, float]]:
    """signal -> (error_max, error_rms, max |y_ref|) of one run's results against the reference, at the
    run's times."""
    t = frame["time"].to_numpy(dtype=float)
    keep = reference.covers(t)
    t = t[keep]
    ref = reference.values(t, signals)
    out = {}
    for s in signals:
        if s not in ref or s not in frame.columns or not len(t):
            out[s] = (math.nan, math.nan, math.nan)
            continue
        d = frame[s].to_numpy(dtype=float)[keep] - ref[s]
        with np.errstate(over="ignore", invalid="ignore"):
            e_max = float(np.max(np.abs(d))) if np.all(np.isfinite(d)) else math.inf
            e_rms = float(np.sqrt(np.mean(d * d))) if math.isfinite(e_max) else math.inf
        out[s] = (e_max, e_rms, float(np.max(np.abs(ref[s]))))
    return out


def diverged(errors: dict[str, tuple[float, float, float]]) -> bool:
    """Whether a run's errors (``run_errors``) say it left the true solution's scale (module docstring)."""
    for e_max, _, scale in errors.values():
        if math.isnan(e_max):
            continue
        if not math.isfinite(e_max) or (math.isfinite(scale) and e_max > DIVERGED * max(scale, 1e-300)):
            return True
    return False


def at_roundoff(error: float, scale: float) -> bool:
    return math.isfinite(scale) and error <= ROUNDOFF * scale


def add_observed_orders(rows: list[dict], axes: list[str], variable_step: set[str]) -> None:
    """Fill ``observed_order`` of ``rows`` (see the module docstring); ``axes``: the settings swept besides
    the grid, ``variable_step``: the algorithms whose step is no step they take."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        r["observed_order"] = math.nan
        if r["algorithm"] in variable_step or not r["outcome"].startswith("completed"):
            continue
        key = (r["algorithm"], r["extrapolation"], r["signal"], *(repr(r.get(a)) for a in axes))
        groups.setdefault(key, []).append(r)
    for group in groups.values():
        group.sort(key=lambda r: r["step"])
        for small, big in zip(group, group[1:]):
            e_s, e_b = small["error_max"], big["error_max"]
            scale = small.get("reference_magnitude", math.nan)
            if not (e_s > 0 and e_b > 0 and math.isfinite(e_s) and math.isfinite(e_b)) or big["step"] <= small["step"]:
                continue
            if at_roundoff(e_s, scale) or at_roundoff(e_b, scale):
                continue
            small["observed_order"] = math.log(e_b / e_s) / math.log(big["step"] / small["step"])
