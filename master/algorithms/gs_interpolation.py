"""Gauss-Seidel with interpolated known inputs (``--gs-interpolation M``).

In a Gauss-Seidel sweep a component that steps after the producer of one of its inputs reads that output at
the step's *end*, y_{n+1}, and holds it over [t_n, t_{n+1}]: half a step ahead of the signal on average, so
the coupling is first order whatever the extrapolation of the other inputs. With M > 0 the receiver gets
instead the mean over the step of the polynomial through y_{n+1}, y_n (M = 1: the trapezoid mean
(y_{n+1} + y_n) / 2) and y_{n-1} (M = 2: (5 y_{n+1} + 8 y_n - y_{n-1}) / 12, the Adams-Moulton weights): the
interpolation counterpart of extrapolation's step mean, whose input integral is right to O(h^{M+2}), hence
global order 2 when the inputs broken at loops are extrapolated with K >= 1 (docs/coupling.md).

Interpolated are the coupled Real outputs of components without a coupled direct-feedthrough output: a
feedthrough output read within the sweep reflects the inputs its component held over the step, not a value
at the step's end, so it is not a sample to interpolate through. After a producer steps, its outputs in the
master's buffer are replaced by their interpolated means for the components after it; when the sweep ends
they are put back to y_{n+1}, so that recording, monitors and the next samples see the values at the
communication point. The sweep is a plain loop over the components' bound operations rather than a compiled
step, because the replacement happens between two components.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..fmi.slave import WARNING
from .compiled import _failer, _step_failer
from .extrapolation import interval_mean_weights


@lru_cache(maxsize=None)
def interpolation_weights(samples: int, ratio: float = 1.0) -> tuple[float, ...]:
    """Weights of y_{n+1}, y_n, ..., y_{n+2-samples} (at t_n + ratio h, t_n, t_n - h, ...; ``ratio`` < 1 for
    a shorter last step) giving the mean over [t_n, t_n + ratio h] of the polynomial through them."""
    return interval_mean_weights((ratio, *(-np.arange(samples - 1, dtype=float))), ratio)


def interpolating_sweep(rt, order: list[int], h: float, ratio: float, extrapolator, samples_back: int,
                        lengths: dict | None = None):
    """The Gauss-Seidel step over ``order`` with the known inputs interpolated through ``samples_back``
    earlier samples (``extrapolator.history``, newest first); ``lengths`` as in ``fixed_step.reference_step``."""
    extrapolator.select()
    out, history = rt.out["Real"], extrapolator.history
    owner = extrapolator.owner
    through = {i for i, _ in extrapolator.refreshed}
    fail, step_failed = _failer(rt), _step_failer(rt)
    weights = [np.array(interpolation_weights(m, ratio)) for m in range(1, samples_back + 2)]
    positions = extrapolator.positions
    plan_ = []                  # per active component: its ops, and which entries of ``positions`` it produces
    for i in order:
        if not rt.active[i]:
            continue
        mine = np.array([j for j, p in enumerate(positions) if owner[int(p)] == i and i not in through],
                        dtype=np.intp)
        plan_.append((i, rt.multiple[i], (lengths or {}).get(i, h * rt.multiple[i]), rt.fast_ops(i), mine))
    produced = np.concatenate([m for *_, m in plan_]) if plan_ else np.zeros(0, dtype=np.intp)
    calls = rt.do_step_calls

    def sweep(n, t):
        fresh = {}
        for i, k, hk, (transfers, setters, step, getters, _), mine in plan_:
            if k > 1 and n % k:
                continue
            for x in transfers:
                x()
            for s in setters:
                if (st := s()) > WARNING:
                    fail(i, "setting inputs", st, t)
            calls[i] += 1
            if (st := step(t, hk)) > WARNING:
                step_failed(i, st, t)
            for g in getters:
                if (st := g()) > WARNING:
                    fail(i, "getting outputs", st, t + hk)
            if len(mine):
                pos = positions[mine]
                fresh[i] = out[pos].copy()
                w = weights[min(len(history), samples_back)]
                out[pos] = w[0] * fresh[i] + (w[1:] @ np.array(history)[:len(w) - 1, mine] if len(w) > 1 else 0.0)
        for i, *_, mine in plan_:
            if i in fresh:
                out[positions[mine]] = fresh[i]
        for i, k, _, (*_, publish), _ in plan_:
            if publish is not None and (n + 1) % k == 0:
                publish()
    sweep.interpolated = [int(p) for p in positions[produced]]
    return sweep
