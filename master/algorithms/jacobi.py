"""Fixed-step Jacobi: every component steps from the values all outputs had at the start of the step."""
from __future__ import annotations

from . import ALGORITHMS
from .base import Algorithm


@ALGORITHMS.register("jacobi")
class Jacobi(Algorithm):
    name = "jacobi"
    gauss_seidel = False
