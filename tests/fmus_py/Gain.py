"""Gain as a pythonfmu FMU (same as tests/fmus_c/Gain.c): y = k u (direct feedthrough)."""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

OUTPUT_DEPENDENCIES = {"y": ["u"]}


class Gain(Fmi2Slave):
    author = "cosim-master tests"
    description = "y = k u (direct feedthrough)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 1.0
        self.u = 0.0
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                    description="gain"))
        self.register_variable(Real("u", causality=Fmi2Causality.input, description="input"))
        self.register_variable(Real("y", causality=Fmi2Causality.output, description="k * u",
                                    getter=lambda: self.k * self.u))

    def do_step(self, current_time, step_size):
        return True
