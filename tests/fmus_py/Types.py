"""Types: a pythonfmu FMU exercising every FMI 2.0 scalar type.

  i_out = i_in + 1        (Integer, feedthrough)
  b_out = not b_in        (Boolean, feedthrough)
  s_out = s_in + "!"      (String, feedthrough)
  r_out = 2 * r_in        (Real, feedthrough)
  counter                 (Integer output, incremented by every doStep)

pythonfmu 0.7 has no Enumeration variable class, so no Enumeration is exposed.
"""
from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String

OUTPUT_DEPENDENCIES = {"i_out": ["i_in"], "b_out": ["b_in"], "s_out": ["s_in"], "r_out": ["r_in"], "counter": []}


class Types(Fmi2Slave):
    author = "cosim-master tests"
    description = "Integer/Boolean/String/Real feedthrough plus a step counter"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.i_in = 0
        self.b_in = False
        self.s_in = "hello"
        self.r_in = 0.0
        self.counter = 0
        disc = Fmi2Variability.discrete
        self.register_variable(Integer("i_in", causality=Fmi2Causality.input, variability=disc))
        self.register_variable(Integer("i_out", causality=Fmi2Causality.output, variability=disc,
                                       getter=lambda: self.i_in + 1))
        self.register_variable(Boolean("b_in", causality=Fmi2Causality.input, variability=disc))
        self.register_variable(Boolean("b_out", causality=Fmi2Causality.output, variability=disc,
                                       getter=lambda: not self.b_in))
        self.register_variable(String("s_in", causality=Fmi2Causality.input, variability=disc))
        self.register_variable(String("s_out", causality=Fmi2Causality.output, variability=disc,
                                      getter=lambda: self.s_in + "!"))
        self.register_variable(Real("r_in", causality=Fmi2Causality.input))
        self.register_variable(Real("r_out", causality=Fmi2Causality.output, getter=lambda: 2.0 * self.r_in))
        self.register_variable(Integer("counter", causality=Fmi2Causality.output, variability=disc))

    def do_step(self, current_time, step_size):
        self.counter += 1
        return True
