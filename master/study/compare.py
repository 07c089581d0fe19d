"""A study's table: every run's error against the reference per signal, and the observed order.

``error_max`` = max over the run's recorded times of |y - y_ref|, ``error_rms`` = the root mean square of the
same differences. ``observed_order`` of a row = the log-log slope of ``error_max`` between its step and the
next larger step of the same algorithm, extrapolation and signal: log(e(H) / e(h)) / log(H / h), empty for
the largest step (and where an error is zero or missing).
"""
from __future__ import annotations

import math

import numpy as np

COLUMNS = ["algorithm", "extrapolation", "step", "signal", "error_max", "error_rms", "fmu_calls", "wall_s",
           "observed_order", "outcome"]


def run_errors(frame, reference, signals: list[str]) -> dict[str, tuple[float, float]]:
    """signal -> (error_max, error_rms) of one run's results against the reference, at the run's times."""
    t = frame["time"].to_numpy(dtype=float)
    keep = reference.covers(t)
    t = t[keep]
    ref = reference.values(t, signals)
    out = {}
    for s in signals:
        if s not in ref or s not in frame.columns or not len(t):
            out[s] = (math.nan, math.nan)
            continue
        d = frame[s].to_numpy(dtype=float)[keep] - ref[s]
        out[s] = (float(np.max(np.abs(d))), float(np.sqrt(np.mean(d * d))))
    return out


def add_observed_orders(rows: list[dict]) -> None:
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        r["observed_order"] = math.nan
        groups.setdefault((r["algorithm"], r["extrapolation"], r["signal"]), []).append(r)
    for group in groups.values():
        group.sort(key=lambda r: r["step"])
        for small, big in zip(group, group[1:]):
            e_s, e_b = small["error_max"], big["error_max"]
            if e_s > 0 and e_b > 0 and math.isfinite(e_s) and math.isfinite(e_b) and big["step"] > small["step"]:
                small["observed_order"] = math.log(e_b / e_s) / math.log(big["step"] / small["step"])
