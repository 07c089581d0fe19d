"""The algorithm interface: how one master step from t to t+h is carried out.

An algorithm sees only the Runtime (slaves, buffers, transfer and bound FMI operations, active and
multi-rate bookkeeping); parsing, initialization and recording never depend on it. A new algorithm
subclasses Algorithm, implements ``prepare`` (and ``step`` if it is not a fixed sequence of calls that
``compiled.compile_step`` can express), and registers itself in ``algorithms/__init__.py``.
"""
from __future__ import annotations


class Algorithm:
    name = "base"
    gauss_seidel = False
    info: dict = {}          # facts for run.json; an algorithm with facts sets its own dict in stepping_order

    def prepare(self, rt, plan, h: float) -> dict:
        """Called once after initialization; returns facts worth recording in run.json."""
        self.rt = rt
        self.h = h
        self.order = self.stepping_order(rt, plan)
        self._build()
        return self.info

    def stepping_order(self, rt, plan) -> list[int]:
        return list(range(len(rt.slaves)))

    def _build(self):
        from .compiled import compile_step
        self._step = compile_step(self.rt, self.order, self.h, self.gauss_seidel)
        self.rt.changed = False

    def step(self, n: int, t: float) -> None:
        if self.rt.changed:      # a monitor took a component out: step the others only
            self._build()
        self._step(n, t)

    def step_sized(self, n: int, t: float, h: float) -> None:
        """One step of another length than the master step (the shorter last step of an interval that is not
        a whole number of steps)."""
        from .compiled import compile_step
        if self.rt.changed:
            self._build()
        compile_step(self.rt, self.order, h, self.gauss_seidel)(n, t)
