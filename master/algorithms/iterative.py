"""Iterative (strong) coupling with rollback (Kuebler and Schiehlen 2000; as DACCOSIM's iterative mode).

Per macro step: save every FMU's state and the master's buffers, then repeat the Gauss-Seidel step from that
saved point with the loop values u (the Real outputs that a component reads before the sweep produces them:
the connections Gauss-Seidel reports as ``loops_broken_at``) set to the current iterate, until the values the
step produces, G(u), agree with u (|G(u) - u| <= atol + rtol |G(u)| for every value) or the maximum of
iterations is reached; the next iterate comes from ``coupling_updates`` (fixed point, Aitken, IQN-ILS). This
is preCICE's serial-implicit coupling: iterating only the loop values keeps the problem small (one value for
a loop of two FMUs with one scalar connection each way, where Aitken is the secant method), and a system
without loops is solved by its first sweep. The first iterate is the value at the step's start, so iteration
1 is the plain Gauss-Seidel step. At convergence every FMU has stepped over [t, t + h] with its inputs held at
the *end-of-step* coupled values: the implicit (monolithic) coupled step for FMUs that hold inputs constant.
Integer, Boolean and String couplings and outputs of components on a step multiple are not iterated (held).

A step that has not converged at ``--coupling-max-iter`` iterations (or whose iterate turns NaN or infinite)
stops the run with one line naming the time, the residual and the update: a coupling iteration that does not
contract only grows (fixed point on a loop gain above 1), and carrying on from its last iterate ran into NaN.

``--coupling-interpolation 1`` (Jacobi waveform iteration with trapezoidal inputs): the iterate U is every
coupled Real output at the step's *end*; every component steps (all from the same inputs, from the saved
point) with its coupled inputs held at the mean over the step of the line from the value at the step's start
to U, (u_n + U) / 2, and G(U) are the coupled outputs at the step's end, the feedthrough components' outputs
read again with their inputs set to the end values (as extrapolation.py does). The fixed point is the
trapezoidal coupled step: global order 2, and on the two-mass oscillator a step map of spectral radius 1 (the
trapezoidal rule's energy conservation) where inputs held at the end-of-step values give 1.106 on the stiff
variant at h = 0.02 (docs/coupling.md).
"""
from __future__ import annotations

import numpy as np

from ..errors import CosimError
from ..runtime import SavedPoint
from . import ALGORITHMS
from .compiled import compile_step
from .extrapolation import InputExtrapolation, coupled_outputs
from .coupling_updates import UPDATES
from .gauss_seidel import GaussSeidel


@ALGORITHMS.register("iterative")
class Iterative(GaussSeidel):
    name = "iterative"
    loop_treatment = ("iterative repeats each step until the connections listed as broken agree with the values "
                      "the step produces (within --coupling-tol)")
    honours_extrapolation = False       # the iteration, not a prediction, settles the inputs

    def configure(self, options) -> None:
        super().configure(options)
        self.rtol = float(options.coupling_tol)
        self.atol = float(options.coupling_atol if options.coupling_atol is not None else options.coupling_tol)
        self.max_iter = int(options.coupling_max_iter)
        if not (self.rtol >= 0 and self.atol >= 0 and self.max_iter >= 1):
            raise CosimError("iterative coupling needs tolerances >= 0 and at least one iteration per step",
                             element="--coupling-tol/--coupling-max-iter")
        if options.coupling_update not in UPDATES:
            raise CosimError(f"unknown coupling update {options.coupling_update!r} (known: {', '.join(UPDATES)})",
                             element="--coupling-update")
        self.update = UPDATES[options.coupling_update]()
        self.interpolate_inputs = int(getattr(options, "coupling_interpolation", 0) or 0)
        if self.interpolate_inputs and self.interpolation:
            raise CosimError("--coupling-interpolation 1 interpolates every coupled input over the step already; "
                             "--gs-interpolation does not apply with it", element="--gs-interpolation")

    def prepare(self, rt, plan, h: float) -> dict:
        cannot = [s.name for s, on in zip(rt.slaves, rt.active) if on and not s.can_save_state]
        if cannot:
            raise CosimError(f"the iterative algorithm rolls steps back, and {', '.join(cannot)} cannot save and "
                             "restore its state (canGetAndSetFMUstate is not true)", file=plan.shown_as,
                             element="component" + ("s" if len(cannot) > 1 else "") + " " + ", ".join(cannot))
        self.plan = plan
        info = super().prepare(rt, plan, h)       # the Gauss-Seidel order and its loops (stepping_order)
        if self.interpolate_inputs:
            info["inputs"] = ("every coupled input held at (u_n + U) / 2 over the step, U the iterate of the "
                              "coupled outputs at its end (trapezoidal, Jacobi sweeps)")
        info.update({"update": self.update.name, "rtol": self.rtol, "atol": self.atol,
                     "max_iterations": self.max_iter, "steps": 0, "iterations_mean": 0.0, "iterations_max": 0,
                     "iterations_total": 0, "not_converged_steps": 0, "rollbacks": 0})
        return info

    def _build(self):
        super()._build()
        if self.interpolate_inputs:
            self._feed = InputExtrapolation(self.rt, self.plan, 0)
            self._feed.select()
            self.positions = self._feed.positions
            self.rt.changed = False
        else:
            self.positions = self._loop_values()

    def _loop_values(self) -> np.ndarray:
        """Positions of the coupled outputs some active component reads before (or while) their own component
        steps in the sweep: the values to iterate."""
        rt = self.rt
        rank = {c: k for k, c in enumerate(self.order)}
        positions, owner = coupled_outputs(rt)
        read_early = {int(p) for i in range(len(rt.names)) if rt.active[i]
                      for p in rt.src["Real"][slice(*rt.in_slice["Real"][i])]
                      if int(p) in owner and rank[owner[int(p)]] >= rank[i]}
        return np.array([p for p in positions if p in read_early], dtype=np.intp)

    def step(self, n: int, t: float) -> None:
        if self.rt.changed:
            self._build()
        self._iterate(self._interpolated(self.h) if self.interpolate_inputs else self._step, n, t, self.h)

    def step_sized(self, n: int, t: float, h: float, lengths: dict | None = None) -> None:
        if self.rt.changed:
            self._build()
        self._iterate(self._interpolated(h, lengths) if self.interpolate_inputs else self._compile(h, lengths), n, t, h)

    def _iterate(self, step, n: int, t: float, h: float) -> None:
        out, pos = self.rt.out["Real"], self.positions
        if not len(pos):            # nothing coupled: one step is the solution
            step(n, t)
            self._count(1, True)
            return
        saved = SavedPoint(self.rt, t)
        self.update.start()
        u = out[pos].copy()
        self._start = u.copy()
        converged = False
        try:
            for k in range(1, self.max_iter + 1):
                if k > 1:
                    saved.restore()
                out[pos] = u
                step(n, t)
                g = out[pos].copy()
                residual = np.abs(g - u)
                if np.all(residual <= self.atol + self.rtol * np.abs(g)):
                    converged = True
                    break
                if k == self.max_iter or not np.all(np.isfinite(g)):
                    break
                u = self.update.next(u, g)
        finally:
            saved.release()
        self._count(k, converged)
        if not converged:
            raise self._not_converged(k, residual, g, t + h)

    def _not_converged(self, k: int, residual: np.ndarray, g: np.ndarray, t: float) -> CosimError:
        names = {p: q for q, p in self.rt.out_pos.items()}
        worst = int(np.nanargmax(np.where(np.isfinite(residual), residual, np.inf))) if len(residual) else 0
        size = residual[worst]
        what = (f"the iterate of {names.get(int(self.positions[worst]), '?')} is {g[worst]}"
                if not np.isfinite(size) else
                f"after {k} iterations |G(u) - u| of {names.get(int(self.positions[worst]), '?')} is {size:.3g}, above "
                f"the tolerance {self.atol + self.rtol * abs(g[worst]):.3g}")
        return CosimError(f"the coupling iteration ({self.update.name}) did not converge: {what} (raise "
                          "--coupling-max-iter, loosen --coupling-tol, or use --coupling-update aitken or iqn-ils, "
                          "which converge where the fixed point does not)",
                          file=getattr(self.plan, "shown_as", None), element="--coupling-max-iter", time=t)

    def _interpolated(self, h: float, lengths: dict | None = None):
        """The Jacobi sweep with trapezoidal inputs (``--coupling-interpolation 1``): out[positions] holds
        the iterate U on entry and G(U) on return."""
        rt, pos, feed = self.rt, self.positions, self._feed
        out = rt.out["Real"]
        fed_through = {i for i, _ in feed.refreshed}
        through_at = np.array([j for j, p in enumerate(pos) if feed.owner[int(p)] in fed_through], dtype=np.intp)
        through = pos[through_at]

        jacobi = compile_step(rt, self.order, h, False, lengths)     # the one Jacobi step (fixed_step)

        def sweep(n: int, t: float) -> None:
            end = out[pos].copy()
            out[pos] = 0.5 * (self._start + end)
            jacobi(n, t)
            # feedthrough outputs at the step's end: from the iterate's end values, not from the mean inputs
            # they were read with
            out[through] = end[through_at]
            feed.refresh(t + h)
        return sweep

    def _count(self, iterations: int, converged: bool) -> None:
        info = self.info
        info["steps"] += 1
        info["iterations_total"] += iterations
        info["iterations_max"] = max(info["iterations_max"], iterations)
        info["iterations_mean"] = info["iterations_total"] / info["steps"]
        info["rollbacks"] += iterations - 1
        info["not_converged_steps"] += not converged
