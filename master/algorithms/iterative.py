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
"""
from __future__ import annotations

import numpy as np

from ..errors import CosimError
from ..runtime import SavedPoint
from . import ALGORITHMS
from .extrapolation import coupled_outputs
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

    def prepare(self, rt, plan, h: float) -> dict:
        cannot = [s.name for s, on in zip(rt.slaves, rt.active) if on and not s.can_save_state]
        if cannot:
            raise CosimError(f"the iterative algorithm rolls steps back, and {', '.join(cannot)} cannot save and "
                             "restore its state (canGetAndSetFMUstate is not true)", file=plan.shown_as,
                             element="component" + ("s" if len(cannot) > 1 else "") + " " + ", ".join(cannot))
        info = super().prepare(rt, plan, h)       # the Gauss-Seidel order and its loops (stepping_order)
        info.update({"update": self.update.name, "rtol": self.rtol, "atol": self.atol,
                     "max_iterations": self.max_iter, "steps": 0, "iterations_mean": 0.0, "iterations_max": 0,
                     "iterations_total": 0, "not_converged_steps": 0, "rollbacks": 0})
        return info

    def _build(self):
        super()._build()
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
        self._iterate(self._step, n, t)

    def step_sized(self, n: int, t: float, h: float) -> None:
        if self.rt.changed:
            self._build()
        self._iterate(self._compile(h), n, t)

    def _iterate(self, step, n: int, t: float) -> None:
        out, pos = self.rt.out["Real"], self.positions
        if not len(pos):            # nothing coupled: one step is the solution
            step(n, t)
            self._count(1, True)
            return
        saved = SavedPoint(self.rt, t)
        self.update.start()
        u = out[pos].copy()
        converged = False
        try:
            for k in range(1, self.max_iter + 1):
                if k > 1:
                    saved.restore()
                out[pos] = u
                step(n, t)
                g = out[pos].copy()
                if np.all(np.abs(g - u) <= self.atol + self.rtol * np.abs(g)):
                    converged = True
                    break
                if k < self.max_iter:
                    u = self.update.next(u, g)
        finally:
            saved.release()
        self._count(k, converged)

    def _count(self, iterations: int, converged: bool) -> None:
        info = self.info
        info["steps"] += 1
        info["iterations_total"] += iterations
        info["iterations_max"] = max(info["iterations_max"], iterations)
        info["iterations_mean"] = info["iterations_total"] / info["steps"]
        info["rollbacks"] += iterations - 1
        info["not_converged_steps"] += not converged
