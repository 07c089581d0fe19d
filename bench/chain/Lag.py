"""Lag as a pythonfmu FMU: the Python twin of bench/chain/lag.c.

x' = (k u - x) / T, y = x; doStep performs one explicit Euler step x += h (k u - x) / T with the same
floating-point operations in the same order as the C FMU, so both give bit-identical trajectories.
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class Lag(Fmi2Slave):
    author = "cosim-master bench/chain"
    description = "first-order lag x' = (k u - x)/T, y = x; one explicit Euler step per doStep"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.T = 1.0
        self.k = 1.0
        self.x0 = 1.0
        self.u = 0.0
        self.y = 1.0
        fixed = dict(causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed)
        self.register_variable(Real("T", description="time constant", **fixed))
        self.register_variable(Real("k", description="gain", **fixed))
        self.register_variable(Real("x0", description="initial state", **fixed))
        self.register_variable(Real("u", causality=Fmi2Causality.input, description="input"))
        self.register_variable(Real("y", causality=Fmi2Causality.output, description="state"))

    def enter_initialization_mode(self):
        self.y = self.x0

    def exit_initialization_mode(self):
        self.y = self.x0

    def do_step(self, current_time, step_size):
        self.y += step_size * (self.k * self.u - self.y) / self.T
        return True
