"""PyMassA: the pythonfmu twin of the C benchmark FMU MassA (tests/fmus_c/MassA.c), with FMU state.

m x'' = -k x + F; input F, outputs x, v (no feedthrough); doStep is exact for F held over the step.
"""
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

from cosim_fmi import StateMixin


def osc_propagate(m, K, f, h, x, v):
    """Exact solution of m x'' = -K x + f over a step h with f constant (tests/fmus_c/oscillator_math.h)."""
    if K == 0.0:
        acc = f / m
        return x + v * h + 0.5 * acc * h * h, v + acc * h
    w = math.sqrt(K / m)
    xe = f / K
    c, s = math.cos(w * h), math.sin(w * h)
    return xe + (x - xe) * c + (v / w) * s, -(x - xe) * w * s + v * c


def parameters(slave, names):
    for name, start, desc in names:
        setattr(slave, name, start)
        slave.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                     description=desc))


class PyMassA(StateMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Mass m on a wall spring k driven by the coupling force F: m x'' = -k x + F"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        parameters(self, [("m", 1.0, "mass"), ("k", 1.0, "wall spring stiffness"), ("x0", 1.0, "initial position"),
                          ("v0", 0.0, "initial velocity")])
        self.F = 0.0
        self.register_variable(Real("F", causality=Fmi2Causality.input, description="coupling force on the mass"))
        self.x, self.v = self.x0, self.v0
        self.register_variable(Real("x", causality=Fmi2Causality.output, description="position"))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="velocity"))

    def exit_initialization_mode(self):
        self.x, self.v = self.x0, self.v0

    def do_step(self, current_time, step_size):
        self.x, self.v = osc_propagate(self.m, self.k, self.F, step_size, self.x, self.v)
        return True
