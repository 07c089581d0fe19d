"""Fixed-step Gauss-Seidel: components step one after another in an order derived from the connection
graph, each reading the outputs its predecessors produced in this same step."""
from __future__ import annotations

from .base import Algorithm
from .ordering import gauss_seidel_order


class GaussSeidel(Algorithm):
    name = "gauss-seidel"

    def prepare(self, rt, plan):
        super().prepare(rt, plan)
        so = gauss_seidel_order(plan, rt.names)
        self.order = so.order
        return {"order": [rt.names[i] for i in so.order],
                "loops_broken_at": [f"{a} -> {b}" for a, b in so.broken]}

    def step(self, n, t, h):
        rt = self.rt
        active, mult = rt.active, rt.multiple
        for i in self.order:
            if active[i] and n % mult[i] == 0:
                rt.transfer(i)
                rt.set_inputs(i, t)
                rt.do_step(i, t, h * mult[i])
                rt.get_outputs(i, t + h * mult[i])
        for i in self.order:
            if mult[i] > 1 and active[i]:
                self._finish(i, n)
