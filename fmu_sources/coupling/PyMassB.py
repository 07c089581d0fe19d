"""PyMassB: the pythonfmu twin of the C benchmark FMU MassB (tests/fmus_c/MassB.c), with FMU state.

m x'' = -(k + kc) x + kc x_in; outputs x, v and F = kc (x - x_in), the force of the coupling spring on the
other mass (direct feedthrough from x_in); doStep is exact for x_in held over the step.
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Real

from cosim_fmi import StateMixin
from PyMassA import osc_propagate, parameters

OUTPUT_DEPENDENCIES = {"x": [], "v": [], "F": ["x_in"]}


class PyMassB(StateMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Mass m on a wall spring k coupled to the other mass by kc; F = kc (x - x_in)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        parameters(self, [("m", 1.0, "mass"), ("k", 1.0, "wall spring stiffness"),
                          ("kc", 1.0, "coupling spring stiffness"), ("x0", 0.0, "initial position"),
                          ("v0", 0.0, "initial velocity")])
        self.x_in = 0.0
        self.register_variable(Real("x_in", causality=Fmi2Causality.input, description="position of the other mass"))
        self.x, self.v = self.x0, self.v0
        self.register_variable(Real("x", causality=Fmi2Causality.output, description="position"))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="velocity"))
        self.register_variable(Real("F", causality=Fmi2Causality.output, getter=lambda: self.kc * (self.x - self.x_in),
                                    description="force of the coupling spring on the other mass: kc (x - x_in)"))

    def exit_initialization_mode(self):
        self.x, self.v = self.x0, self.v0

    def do_step(self, current_time, step_size):
        self.x, self.v = osc_propagate(self.m, self.k + self.kc, self.kc * self.x_in, step_size, self.x, self.v)
        return True
