"""Integrator as a pythonfmu FMU (same as tests/fmus_c/Integrator.c).

x' = a x + u, y = x; doStep performs exactly one explicit Euler step
x += h (a x + u).
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

OUTPUT_DEPENDENCIES = {"y": []}


class Integrator(Fmi2Slave):
    author = "cosim-master tests"
    description = "x' = a x + u, y = x; one explicit Euler step per doStep"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.a = 0.0
        self.x0 = 0.0
        self.u = 0.0
        self._x = 0.0
        self._initialized = False
        self.register_variable(Real("a", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description="linear feedback coefficient"))
        self.register_variable(Real("x0", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description="initial state"))
        self.register_variable(Real("u", causality=Fmi2Causality.input, description="input"))
        self.register_variable(Real("y", causality=Fmi2Causality.output, description="state",
                                    getter=lambda: self._x if self._initialized else self.x0))

    def exit_initialization_mode(self):
        self._x = self.x0
        self._initialized = True

    def do_step(self, current_time, step_size):
        self._x += step_size * (self.a * self._x + self.u)
        return True
