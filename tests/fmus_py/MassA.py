"""MassA as a pythonfmu FMU (same math and variable names as tests/fmus_c/MassA.c).

m x'' = -k x + F; doStep integrates exactly with F held constant over the step.
"""
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

# read by tests/fmu_factory.py to write ModelStructure/Outputs dependencies
OUTPUT_DEPENDENCIES = {"x": [], "v": []}


def osc_propagate(m, K, f, h, x, v):
    """Exact solution of m x'' = -K x + f over a step h (f constant)."""
    if K == 0.0:
        acc = f / m
        return x + v * h + 0.5 * acc * h * h, v + acc * h
    w = math.sqrt(K / m)
    xe = f / K
    c, s = math.cos(w * h), math.sin(w * h)
    return xe + (x - xe) * c + (v / w) * s, -(x - xe) * w * s + v * c


class MassA(Fmi2Slave):
    author = "cosim-master tests"
    description = "Mass m on a wall spring k driven by the coupling force F: m x'' = -k x + F"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.m = 1.0
        self.k = 1.0
        self.x0 = 1.0
        self.v0 = 0.0
        self.F = 0.0
        self._x = self.x0
        self._v = self.v0
        self._initialized = False
        for name, desc in (("m", "mass"), ("k", "wall spring stiffness"), ("x0", "initial position"),
                           ("v0", "initial velocity")):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed, description=desc))
        self.register_variable(Real("F", causality=Fmi2Causality.input,
                                    description="coupling force acting on the mass"))
        self.register_variable(Real("x", causality=Fmi2Causality.output, description="position",
                                    getter=lambda: self._x if self._initialized else self.x0))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="velocity",
                                    getter=lambda: self._v if self._initialized else self.v0))

    def exit_initialization_mode(self):
        self._x, self._v = self.x0, self.v0
        self._initialized = True

    def do_step(self, current_time, step_size):
        if not (self.m > 0.0) or self.k < 0.0:
            self.log(f"MassA: invalid parameters m={self.m} k={self.k}", Fmi2Status.error)
            return False
        self._x, self._v = osc_propagate(self.m, self.k, self.F, step_size, self._x, self._v)
        return True
