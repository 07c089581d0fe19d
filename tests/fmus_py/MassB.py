"""MassB as a pythonfmu FMU (same math and variable names as tests/fmus_c/MassB.c).

m x'' = -k x - kc (x - x_in) = -(k + kc) x + kc x_in
F = kc (x - x_in) is the force of the coupling spring on mass 1 (direct
feedthrough from x_in).  doStep is exact for x_in held constant.
"""
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

OUTPUT_DEPENDENCIES = {"x": [], "v": [], "F": ["x_in"]}


def osc_propagate(m, K, f, h, x, v):
    """Exact solution of m x'' = -K x + f over a step h (f constant)."""
    if K == 0.0:
        acc = f / m
        return x + v * h + 0.5 * acc * h * h, v + acc * h
    w = math.sqrt(K / m)
    xe = f / K
    c, s = math.cos(w * h), math.sin(w * h)
    return xe + (x - xe) * c + (v / w) * s, -(x - xe) * w * s + v * c


class MassB(Fmi2Slave):
    author = "cosim-master tests"
    description = "Mass m on a wall spring k coupled to mass 1 by kc; F = kc (x - x_in)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.m = 1.0
        self.k = 1.0
        self.kc = 1.0
        self.x0 = 0.0
        self.v0 = 0.0
        self.x_in = 0.0
        self._x = self.x0
        self._v = self.v0
        self._initialized = False
        for name, desc in (("m", "mass"), ("k", "wall spring stiffness"), ("kc", "coupling spring stiffness"),
                           ("x0", "initial position"), ("v0", "initial velocity")):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed, description=desc))
        self.register_variable(Real("x_in", causality=Fmi2Causality.input, description="position of mass 1"))
        self.register_variable(Real("x", causality=Fmi2Causality.output, description="position",
                                    getter=self._get_x))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="velocity",
                                    getter=lambda: self._v if self._initialized else self.v0))
        self.register_variable(Real("F", causality=Fmi2Causality.output,
                                    description="force of the coupling spring on mass 1: kc (x - x_in)",
                                    getter=lambda: self.kc * (self._get_x() - self.x_in)))

    def _get_x(self):
        return self._x if self._initialized else self.x0

    def exit_initialization_mode(self):
        self._x, self._v = self.x0, self.v0
        self._initialized = True

    def do_step(self, current_time, step_size):
        K = self.k + self.kc
        if not (self.m > 0.0) or K < 0.0:
            self.log(f"MassB: invalid parameters m={self.m} k+kc={K}", Fmi2Status.error)
            return False
        self._x, self._v = osc_propagate(self.m, K, self.kc * self.x_in, step_size, self._x, self._v)
        return True
