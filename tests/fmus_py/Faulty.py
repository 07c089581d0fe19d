"""Faulty as a pythonfmu FMU (same contract as tests/fmus_c/Faulty.c).

Output y = time.  The first doStep whose end time exceeds fail_time
(t + h > fail_time + 1e-9) misbehaves according to the Integer parameter mode:
  0 -> never fails
  1 -> logs an error and raises RuntimeError (pythonfmu turns the exception
       into an error status of fmi2DoStep)
  2 -> logs a discard message and returns False, which pythonfmu 0.7 reports
       as fmi2Discard with fmi2GetBooleanStatus(fmi2Terminated) = true
  3 -> logs a fatal message and kills the process with os.abort()
"""
import os

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

OUTPUT_DEPENDENCIES = {"y": []}


class Faulty(Fmi2Slave):
    author = "cosim-master tests"
    description = "y = time; fails at fail_time according to mode (0 none, 1 error, 2 discard, 3 abort)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.fail_time = 0.5
        self.mode = 1
        self._time = 0.0
        self.register_variable(Real("fail_time", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed,
                                    description="the first step ending after this time fails"))
        self.register_variable(Integer("mode", causality=Fmi2Causality.parameter,
                                       variability=Fmi2Variability.fixed,
                                       description="0 no failure, 1 error, 2 discard, 3 crash (abort)"))
        self.register_variable(Real("y", causality=Fmi2Causality.output, description="simulation time",
                                    getter=lambda: self._time))

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self._time = start_time

    def do_step(self, current_time, step_size):
        if current_time + step_size > self.fail_time + 1e-9:
            if self.mode == 1:
                self.log(f"Faulty: injected error in doStep(t={current_time}, h={step_size}), "
                         f"fail_time={self.fail_time}", Fmi2Status.error)
                raise RuntimeError(f"Faulty: injected error at t={current_time}")
            if self.mode == 2:
                self.log(f"Faulty: injected discard in doStep(t={current_time}, h={step_size}), "
                         f"fail_time={self.fail_time}", Fmi2Status.discard)
                return False
            if self.mode == 3:
                self.log(f"Faulty: injected crash (os.abort) in doStep(t={current_time}, h={step_size})",
                         Fmi2Status.fatal)
                os.abort()
        self._time = current_time + step_size
        return True
