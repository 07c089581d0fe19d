"""Fixed-step Gauss-Seidel: components step one after another in an order derived from the connection
graph, each reading the outputs its predecessors produced in this same step."""
from __future__ import annotations

from . import ALGORITHMS
from .base import Algorithm
from .ordering import gauss_seidel_order


@ALGORITHMS.register("gauss-seidel")
class GaussSeidel(Algorithm):
    name = "gauss-seidel"
    gauss_seidel = True
    honours_interpolation = True
    loop_treatment = ("gauss-seidel steps it in order and the connections listed as broken read the previous "
                      "step")

    def stepping_order(self, rt, plan):
        so = gauss_seidel_order(plan, rt.names)
        self.info = {"order": [rt.names[i] for i in so.order],
                     "loops_broken_at": [f"{a} -> {b}" for a, b in so.broken]}
        return so.order

    def prepare(self, rt, plan, h: float) -> dict:
        info = super().prepare(rt, plan, h)
        if self.interpolation:
            from .gs_interpolation import interpolation_weights
            names = {p: q for q, p in rt.out_pos.items()}
            self.info = info = {**info, "interpolation": {
                "samples_besides_the_new_one": self.interpolation, "to": "mean over the step",
                "weights": list(interpolation_weights(self.interpolation + 1)),
                "interpolated": [names[p] for p in self._step_interpolated]}}
        return info

    def _sweep(self, h: float, lengths: dict | None = None):
        if not self.interpolation:
            return super()._sweep(h, lengths)
        from .gs_interpolation import interpolating_sweep
        sweep = interpolating_sweep(self.rt, self.order, h, h / self.h, self._extrapolator, self.interpolation, lengths)
        self._step_interpolated = sweep.interpolated
        return sweep
