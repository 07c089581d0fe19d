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
    loop_treatment = ("gauss-seidel steps it in order and the connections listed as broken read the previous "
                      "step")

    def stepping_order(self, rt, plan):
        so = gauss_seidel_order(plan, rt.names)
        self.info = {"order": [rt.names[i] for i in so.order],
                     "loops_broken_at": [f"{a} -> {b}" for a, b in so.broken]}
        return so.order
