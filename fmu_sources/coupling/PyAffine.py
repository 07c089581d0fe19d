"""PyAffine: the pythonfmu twin of the C benchmark FMU Affine (fmu_sources/coupling/c/Affine.c), with FMU state.

y = a u + b + c sin(w t), direct feedthrough from u, no state but the time.
"""
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Real

from cosim_fmi import StateMixin
from PyMassA import parameters

OUTPUT_DEPENDENCIES = {"y": ["u"]}


class PyAffine(StateMixin, Fmi2Slave):
    author = "cosim-master"
    description = "y = a u + b + c sin(w t) (direct feedthrough)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        parameters(self, [("a", 0.5, "gain of the input"), ("b", 1.0, "offset"), ("c", 0.0, "amplitude of the forcing"),
                          ("w", 1.0, "angular frequency of the forcing")])
        self.u = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input, description="input"))
        self.register_variable(Real("y", causality=Fmi2Causality.output, description="a u + b + c sin(w t)",
                                    getter=lambda: self.a * self.u + self.b + self.c * math.sin(self.w * self.time)))
        self.time = 0.0

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.time = float(start_time)

    def do_step(self, current_time, step_size):
        self.time = current_time + step_size
        return True
