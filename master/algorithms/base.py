"""The algorithm interface: how one master step from t to t+h is carried out.

An algorithm sees only the Runtime's primitives (transfer, set_inputs, do_step, get_outputs, publish)
and the active/multi-rate bookkeeping; parsing, initialization and recording never depend on it.
A new algorithm subclasses Algorithm and registers itself in ``algorithms/__init__.py``.
"""
from __future__ import annotations


class Algorithm:
    name = "base"

    def prepare(self, rt, plan) -> dict:
        """Called once after initialization; returns facts worth recording in run.json."""
        self.rt = rt
        self.order = list(range(len(rt.slaves)))
        return {}

    def due(self, i: int, n: int) -> bool:
        """A component with step multiple k steps at master steps n = 0, k, 2k, ..."""
        return n % self.rt.multiple[i] == 0

    def step(self, n: int, t: float, h: float) -> None:
        raise NotImplementedError

    def _finish(self, i: int, n: int) -> None:
        """Publish a multi-rate component's outputs once the master reaches the end of its macro step."""
        rt = self.rt
        k = rt.multiple[i]
        if k > 1 and (n + 1) % k == 0:
            rt.publish(i)
