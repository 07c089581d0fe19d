"""Fixed-step Jacobi: every component steps from the values all outputs had at the start of the step."""
from __future__ import annotations

from . import ALGORITHMS
from .base import Algorithm


@ALGORITHMS.register("jacobi")
class Jacobi(Algorithm):
    name = "jacobi"
    gauss_seidel = False
    honours_threads = True
    honours_input_derivatives = True
    loop_treatment = "jacobi reads every input from the previous step, so the loop only delays values by a step"
