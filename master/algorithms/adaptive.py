"""Adaptive communication steps with a local error estimate, a PI controller and rejection by rollback.

Each master step [t, t + H] (``--step``: the grid that monitors and the record grid sit on) is covered by one
or more *adaptive steps* h <= min(--max-step, H); a step that would pass the master step's end is shortened so
that equal steps land on it exactly (``fit_to_grid``), so recorded values are the FMUs' own values at the
record points, never interpolated. Every adaptive step is a Jacobi step: all components step from the same
coupled inputs, the mean over the step of the polynomial through the last K + 1 accepted samples of each
coupled output (``--extrapolation K``; K = 0 holds the last value), on the actual, uneven step times. After
each step the components with a direct-feedthrough coupled output get their inputs again and are read once
more (as extrapolation.py does), so every sample is the value at the step's end (with K = 0 too: the inputs
of a step are as a ``jacobi`` step's of that length, the feedthrough outputs recorded at its end are
consistent with the other outputs there; ECCO, with its own estimate, keeps Jacobi's samples).

Error estimates (``--error-estimate``):
- ``extrapolation`` (default): the difference between the value the predictor polynomial gives at the
  step's end and the coupled output the FMUs computed there, per coupled value: the error of the input the
  FMUs were given, O(h^(K+1)). It costs no extra FMU step: only a rejected step is repeated. It is the
  "explicit predictor/corrector" error indicator reviewed by Kyllingstad, Sadjina and Skjong (2024), on the
  step-mean extrapolation of Busch (2016).
- ``doubling``: the step is taken once with h and, after a rollback, as two steps of h/2; the difference of
  all Real outputs read after every step, divided by 2^p - 1 (p = 1 for held inputs, 2 with extrapolation:
  the global order, docs/coupling.md), estimates the local error of the two half steps, which are kept
  (Richardson; Hairer, Noersett and Wanner I, sec. II.4). Three sweeps and a rollback per step.

A step is accepted when max_i |e_i| / (atol + rtol max(|y_i|, M_i)) <= 1, with M_i the largest |y_i| of the
accepted steps so far (the variable's magnitude: a coupling force of ~1000 and a position of ~1 each get a
tolerance on their own scale, and an oscillating value passing through zero keeps the tolerance of its
amplitude instead of falling to atol, which drove the steps of the stiff oscillator to the minimum step);
otherwise every FMU and the master's buffers
are restored (runtime.SavedPoint) and the step is retried shorter. At the minimum step a step is accepted
whatever its estimate and counted (``accepted_above_tolerance``). The next step comes from the PI controller
of step_control.py. Components on a step multiple k step once per k master steps (with the first adaptive
step of the master step, from its inputs there) and publish at the end of their macro step, as with the
fixed-step algorithms.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import CosimError
from ..fmi.slave import WARNING
from ..runtime import SavedPoint
from . import ALGORITHMS
from .base import Algorithm
from .extrapolation import InputExtrapolation, coupled_outputs
from .step_control import StepLimits, StepStats, fit_to_grid, gustafsson

ESTIMATES = ("extrapolation", "doubling")


def predictor_weights(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For samples at ``nodes`` (times in units of the coming step, relative to its start: 0, negative
    values), the weights of the polynomial through them giving its mean over [0, 1] and its value at 1."""
    from numpy.polynomial import polynomial as P
    mean, end = [], []
    for j in range(len(nodes)):
        others = np.delete(nodes, j)
        basis = P.polyfromroots(others) / np.prod(nodes[j] - others)
        antiderivative = P.polyint(basis)
        mean.append(P.polyval(1.0, antiderivative) - P.polyval(0.0, antiderivative))
        end.append(P.polyval(1.0, basis))
    return np.array(mean), np.array(end)


def cannot_roll_back(rt, plan, algorithm: str) -> CosimError | None:
    cannot = [s.name for s, on in zip(rt.slaves, rt.active) if on and not s.can_save_state]
    if not cannot:
        return None
    return CosimError(f"the {algorithm} algorithm rolls rejected steps back, and {', '.join(cannot)} cannot save "
                      "and restore its state (canGetAndSetFMUstate is not true)", file=plan.shown_as,
                      element="component" + ("s" if len(cannot) > 1 else "") + " " + ", ".join(cannot))


@ALGORITHMS.register("adaptive")
class Adaptive(Algorithm):
    name = "adaptive"
    loop_treatment = ("adaptive sweeps in Jacobi fashion inside each of its steps, so the loop delays values by "
                      "one adaptive step")
    rejects = True                   # a step above the tolerance is rolled back and retried
    honours_per_output_extrapolation = False     # its predictor takes one order for all outputs (docs/coupling.md)
    _lengths: dict = {}              # step_sized's lengths, for the master step it runs
    defaults = {"step_rtol": 1e-4, "min_step_ratio": 1e-6, "initial_ratio": 1.0}

    def configure(self, options) -> None:
        super().configure(options)
        self.options = options
        self.estimate = getattr(options, "error_estimate", None) or "extrapolation"
        if self.estimate not in ESTIMATES:
            raise CosimError(f"unknown error estimate {self.estimate!r} (known: {', '.join(ESTIMATES)})",
                             element="--error-estimate")

    def prepare(self, rt, plan, h: float) -> dict:
        if self.rejects and (error := cannot_roll_back(rt, plan, self.name)) is not None:
            raise error
        self.rt, self.plan, self.h = rt, plan, h
        self._step = None        # no compiled step (the supervisor maps a crash in one to its component)
        self.limits = StepLimits.from_options(self.options, h, self.defaults)
        self.stats = StepStats()
        self.h_next = self.limits.h_initial
        self.controller = gustafsson(1.0, h_min=self.limits.h_min, h_max=self.limits.h_max)
        self._feed = InputExtrapolation(rt, plan, self.extrapolation)
        self._refresh_held = type(self)._attempt is Adaptive._attempt
        self.history: list[tuple[float | None, np.ndarray]] = []    # samples of the coupled outputs, newest first
        self.positions = np.zeros(0, dtype=np.intp)
        self._build()
        self.info = {"error_estimate": self.estimate, "extrapolation": self.extrapolation, **self.limits.describe(),
                     "controller": "PI.3.4 (Gustafsson): k_I = 0.3/q, k_P = 0.4/q, safety 0.9, rate 0.2..5",
                     "record_grid": "hit exactly: steps are shortened to end on every master step",
                     **self.stats.describe()}
        return self.info

    # -- what is stepped and compared -----------------------------------------------------------------
    def _build(self, t: float | None = None) -> None:
        """The active components, the coupled values, and the outputs step doubling compares; the history
        restarts (at t: None until the first step) when the coupled values change."""
        rt = self.rt
        self._feed.select()                 # the feedthrough components refreshed after each step
        positions, _ = coupled_outputs(rt)
        if not self.history or not np.array_equal(positions, self.positions):
            self.history[:] = [(t, rt.out["Real"][positions].copy())]
        self.positions = positions
        self.components = [(i, rt.multiple[i], *rt.fast_ops(i)) for i in range(len(rt.slaves)) if rt.active[i]]
        firsts = [(rt.out_slice["Real"][i][0], rt.step_reads(i, "Real")) for i, k, *_ in self.components if k == 1]
        self.outputs = np.array([p for a, m in firsts for p in range(a, a + m)], dtype=np.intp)
        # the magnitudes M_i of the compared values (the error norm), kept per output position across rebuilds
        out = rt.out["Real"]
        known = dict(zip(self._mag_at.tolist(), self._mag.tolist())) if hasattr(self, "_mag_at") else {}
        self._mag_at = np.union1d(positions, self.outputs).astype(np.intp)
        now = np.abs(out[self._mag_at])
        self._mag = np.where(np.isfinite(now), now, 0.0)
        self._mag = np.maximum(self._mag, [known.get(int(p), 0.0) for p in self._mag_at])
        self._mag_of = {"positions": np.searchsorted(self._mag_at, positions),
                        "outputs": np.searchsorted(self._mag_at, self.outputs)}
        rt.changed = False

    # -- stepping ---------------------------------------------------------------------------------------
    def step(self, n: int, t: float) -> None:
        self._advance(n, t, self.h)

    def step_sized(self, n: int, t: float, h: float, lengths: dict | None = None) -> None:
        self._lengths = lengths or {}       # the last macro steps of components on a step multiple, cut to the stop
        try:
            self._advance(n, t, h)
        finally:
            self._lengths = {}

    def _advance(self, n: int, t0: float, length: float) -> None:
        """The master step [t0, t0 + length] in accepted adaptive steps."""
        if self.rt.changed:
            self._build(t0)
        if self.history[0][0] is None:
            self.history[0] = (t0, self.history[0][1])
        t_end, t, first = t0 + length, t0, True
        while first or t_end - t > 1e-12 * length:
            h = self._one_step(n, t, self.h_next, first, t_end)
            t = t_end if h >= t_end - t else t + h
            first = False
            if self.rt.stop_reason is not None:     # an FMU asked to end the simulation: no further doStep
                break
        for i, k, _, _, _, _, publish in self.components:
            if k > 1 and publish is not None and (n + 1) % k == 0:
                publish()
        self.info.update(self.stats.describe())

    def _one_step(self, n: int, t: float, wanted: float, first: bool, t_end: float) -> float:
        """Take one adaptive step from t of the controller's length ``wanted`` (shortened to land on the
        master step's end), retrying shorter while it is rejected; returns its length."""
        h = fit_to_grid(t_end - t, wanted)
        stats, saved = self.stats, None
        if self.rejects or self.estimate == "doubling":
            saved = SavedPoint(self.rt, t)
            self._kept = list(self.history)
        after_rejection = False
        try:
            while True:
                r, q, extra = self._attempt(n, t, h, first, saved)
                if not math.isfinite(r) and not self.options.allow_nonfinite:
                    # no shorter step mends a NaN or an overflow: stop here, not at the master step's end
                    if (error := self.rt.nonfinite_error(t + h)) is not None:
                        raise error
                if not self.rejects or r <= 1.0 or h <= self.limits.h_min * (1 + 1e-12) or not math.isfinite(r):
                    stats.above_tolerance += self.rejects and r > 1.0
                    break
                saved.restore()
                self.history[:] = self._kept
                stats.rejected += 1
                stats.rollbacks += 1
                h = fit_to_grid(t_end - t, self.controller.rejected(h, r, q))
                after_rejection = True
        finally:
            if saved is not None:
                saved.release()
        stats.accept(t + h, h, r, extra)
        self._remember_magnitudes()
        self._set_gains(q)
        # a step shortened only to land on the master step's end: the controller goes on from the step it
        # wanted (else every master step would pull it back to its equal share)
        self.h_next = self.controller.accepted(h if after_rejection else max(h, wanted), r, after_rejection)
        return h

    def _set_gains(self, q: float) -> None:
        self.controller.k_i, self.controller.k_p = 0.3 / q, 0.4 / q

    def _attempt(self, n: int, t: float, h: float, first: bool, saved) -> tuple[float, float, tuple]:
        """One try of the step [t, t + h]: (normalised error estimate, its power of h, extra columns)."""
        out = self.rt.out["Real"]
        if self.estimate == "extrapolation":
            samples = len(self.history)
            predicted = self._sweep(n, t, h, first)
            return (self._norm(out[self.positions] - predicted, out[self.positions], "positions"),
                    float(samples), ())
        samples = len(self.history)
        self._sweep(n, t, h, first)
        big = out[self.outputs].copy()
        saved.restore()
        self.history[:] = self._kept
        self.stats.rollbacks += 1
        self._sweep(n, t, h / 2, first)
        self._sweep(n, t + h / 2, h / 2, False)
        p = 1 if samples == 1 else 2
        small = out[self.outputs]
        return self._norm((small - big) / (2 ** p - 1), small, "outputs"), float(p + 1), ()

    def _norm(self, error: np.ndarray, values: np.ndarray, which: str) -> float:
        """max_i |e_i| / (atol + rtol max(|y_i|, M_i)) (module docstring); ``which``: "positions" (the coupled
        values) or "outputs" (the values step doubling compares)."""
        if not len(error):
            return 0.0
        magnitude = np.maximum(np.abs(values), self._mag[self._mag_of[which]])
        return float(np.max(np.abs(error) / (self.limits.atol + self.limits.rtol * magnitude)))

    def _remember_magnitudes(self) -> None:
        """After an accepted step: the largest finite |y_i| so far of every compared value."""
        now = np.abs(self.rt.out["Real"][self._mag_at])
        np.maximum(self._mag, np.where(np.isfinite(now), now, 0.0), out=self._mag)

    def _sweep(self, n: int, t: float, h: float, first: bool) -> np.ndarray:
        """A Jacobi step [t, t + h] from the extrapolated coupled values; appends the new sample to the
        history and returns what the predictor said for the step's end."""
        rt, pos, history = self.rt, self.positions, self.history
        out = rt.out["Real"]
        values = np.array([y for _, y in history])
        if len(history) > 1:
            nodes = np.array([(s - t) / h for s, _ in history])
            mean, end = predictor_weights(nodes)
            out[pos] = mean @ values
            predicted = end @ values
        else:
            out[pos] = values[0]
            predicted = values[0]
        self._inputs_held()
        stepped = []
        for i, k, transfers, setters, do_step, getters, _ in self.components:
            if k > 1 and not (first and n % k == 0):
                continue
            for x in transfers:
                x()
            for s in setters:
                if (st := s()) > WARNING:
                    raise rt.slaves[i].fail("setting inputs", st, t)
            hk = h if k == 1 else self._lengths.get(i, self.h * k)
            if (st := do_step(t, hk)) > WARNING and not rt.ends_run_on_request(i, st):
                raise rt.slaves[i].fail("doStep", st, t)
            rt.do_step_calls[i] += 1
            stepped.append((i, getters))
        for i, getters in stepped:
            for g in getters:
                if (st := g()) > WARNING:
                    raise rt.slaves[i].fail("getting outputs", st, t + h)
        self.stats.fmu_calls += len(stepped)
        # consistent samples (extrapolation.py), held inputs too when this class's error estimate reads them: a
        # feedthrough output read with the inputs it held carries the previous step's input change, an "error"
        # that no shorter step reduces, which drove the stiff oscillator's steps to the minimum step (an
        # algorithm with an estimate of its own, ECCO, keeps Jacobi's held-input samples, as libcosim has them)
        if self.extrapolation or self._refresh_held:
            self._feed.refresh(t + h)
        history.insert(0, (t + h, out[pos].copy()))
        del history[self.extrapolation + 1:]
        return predicted

    def _inputs_held(self) -> None:
        """Called when the coupled values of a step are set, before any component steps."""

    def finish(self, out_dir) -> dict:
        """steps.csv: one row per accepted step (its end, length, normalised error estimate, ...); not for
        runs that write summaries only (campaigns: ``products="summary"``)."""
        if out_dir is not None and self.stats.rows and getattr(self.options, "products", "all") != "summary":
            import csv
            import os
            tmp = out_dir / "steps.csv.tmp"
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f)
                w.writerow(self.step_columns())
                w.writerows(self.stats.rows)
            os.replace(tmp, out_dir / "steps.csv")
        return self.stats.describe()        # also when the run failed within a master step

    def step_columns(self) -> list[str]:
        return ["time", "step", "error_estimate"]
