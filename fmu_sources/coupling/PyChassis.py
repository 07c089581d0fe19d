"""PyChassis: the chassis of the quarter-car benchmark (ssp/coupling/quarter_car_*.ssp), a pythonfmu FMU with FMU
state. The chassis mass m_C sits on the suspension: spring k_C and a damper, linear (d2 = 0) or progressive,
F_d = d dv + d2 dv |dv| with dv = v_C - v_W. It reads the wheel's velocity v_W (the flow of the power bond) and
returns the suspension force on the wheel (the effort, direct feedthrough through the damper):

    z' = v_C - v_W  (z = x_C - x_W, the suspension deflection),   m_C v_C' = -F,   F = k_C z + F_d(v_C - v_W)

Outputs F, z and v. doStep integrates with v_W held, by classical Runge-Kutta in substeps of at most
`max_substep`.
"""
from pythonfmu import Fmi2Causality, Fmi2Slave, Real

from cosim_fmi import StateMixin
from PyWheel import parameters, rk4

OUTPUT_DEPENDENCIES = {"F": ["v_in"], "z": [], "v": []}


class PyChassis(StateMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Quarter-car chassis on the suspension spring and a linear or progressive damper"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        parameters(self, [("m", 400.0, "chassis mass [kg]"), ("k", 15000.0, "suspension stiffness [N/m]"),
                          ("d", 1000.0, "linear damping [N s/m]"),
                          ("d2", 0.0, "progressive damping [N s^2/m^2]: F_d = d dv + d2 dv |dv|"),
                          ("z0", 0.0, "initial deflection [m]"), ("v0", 0.0, "initial velocity [m/s]"),
                          ("max_substep", 1e-4, "largest Runge-Kutta substep [s]")])
        self.v_in = 0.0
        self.register_variable(Real("v_in", causality=Fmi2Causality.input,
                                    description="wheel velocity [m/s] (flow)"))
        self.z, self.v = self.z0, self.v0
        self.register_variable(Real("F", causality=Fmi2Causality.output, getter=lambda: self.force(self.z, self.v),
                                    description="suspension force on the wheel, upwards [N] (effort)"))
        self.register_variable(Real("z", causality=Fmi2Causality.output, description="suspension deflection [m]"))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="chassis velocity [m/s]"))

    def force(self, z, v):
        dv = v - self.v_in
        return self.k * z + self.d * dv + self.d2 * dv * abs(dv)

    def exit_initialization_mode(self):
        self.z, self.v = self.z0, self.v0

    def _rhs(self, t, y):
        z, v = y
        return v - self.v_in, -self.force(z, v) / self.m

    def do_step(self, current_time, step_size):
        self.z, self.v = rk4(self._rhs, current_time, (self.z, self.v), step_size, self.max_substep)
        return True
