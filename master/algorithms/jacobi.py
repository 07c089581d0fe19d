"""Fixed-step Jacobi: every component steps from the values all outputs had at the start of the step."""
from __future__ import annotations

from .base import Algorithm


class Jacobi(Algorithm):
    name = "jacobi"

    def step(self, n, t, h):
        rt = self.rt
        active, mult = rt.active, rt.multiple
        due = [i for i in self.order if active[i] and n % mult[i] == 0]
        # all inputs are computed before any component steps, so nobody sees a value from this step
        for i in due:
            rt.transfer(i)
        for i in due:
            rt.set_inputs(i, t)
            rt.do_step(i, t, h * mult[i])
        for i in due:
            rt.get_outputs(i, t + h * mult[i])
        for i in self.order:
            if mult[i] > 1 and active[i]:
                self._finish(i, n)
