"""PyWheel: the wheel of the quarter-car benchmark (ssp/coupling/quarter_car_*.ssp), a pythonfmu FMU with FMU
state. The wheel mass m_W rides on the tyre spring k_W (damping d_W) over the road r(t), a cosine bump of height
`bump` from `bump_start` lasting `bump_length` seconds, and is pushed by the suspension force F from the chassis:

    m_W v_W' = F - k_W (x_W - r(t)) - d_W (v_W - r'(t)),   x_W' = v_W

Input F (the effort of the power bond), outputs v (its flow) and x. Positions are deviations from the static
equilibrium (no gravity). doStep integrates with F held, by classical Runge-Kutta in substeps of at most
`max_substep` (the subsystem's own error stays far below the coupling's).
"""
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

from cosim_fmi import StateMixin

OUTPUT_DEPENDENCIES = {"x": [], "v": []}


def parameters(slave, names):
    for name, start, desc in names:
        setattr(slave, name, start)
        slave.register_variable(Real(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed,
                                     description=desc))


def rk4(rhs, t, y, h, max_substep):
    """y after h by classical Runge-Kutta in equal substeps of at most max_substep (y a tuple)."""
    n = max(1, math.ceil(h / max_substep - 1e-9))
    dt = h / n
    for i in range(n):
        ti = t + i * dt
        k1 = rhs(ti, y)
        k2 = rhs(ti + dt / 2, tuple(a + dt / 2 * b for a, b in zip(y, k1)))
        k3 = rhs(ti + dt / 2, tuple(a + dt / 2 * b for a, b in zip(y, k2)))
        k4 = rhs(ti + dt, tuple(a + dt * b for a, b in zip(y, k3)))
        y = tuple(a + dt / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(y, k1, k2, k3, k4))
    return y


def road(t, height, start, length):
    """r(t) and r'(t) of the cosine bump."""
    if not (start <= t <= start + length) or length <= 0.0:
        return 0.0, 0.0
    phase = 2.0 * math.pi * (t - start) / length
    return height * (1.0 - math.cos(phase)) / 2.0, height * math.pi / length * math.sin(phase)


class PyWheel(StateMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Quarter-car wheel on the tyre spring over a road bump, pushed by the suspension force F"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        parameters(self, [("m", 40.0, "wheel mass [kg]"), ("k", 150000.0, "tyre stiffness [N/m]"),
                          ("d", 0.0, "tyre damping [N s/m]"), ("bump", 0.05, "height of the road bump [m]"),
                          ("bump_start", 0.5, "time the bump starts [s]"),
                          ("bump_length", 0.2, "time the wheel takes over the bump [s]"),
                          ("x0", 0.0, "initial position [m]"), ("v0", 0.0, "initial velocity [m/s]"),
                          ("max_substep", 1e-4, "largest Runge-Kutta substep [s]")])
        self.F = 0.0
        self.register_variable(Real("F", causality=Fmi2Causality.input,
                                    description="suspension force on the wheel, upwards [N] (effort)"))
        self.x, self.v = self.x0, self.v0
        self.register_variable(Real("x", causality=Fmi2Causality.output, description="wheel position [m]"))
        self.register_variable(Real("v", causality=Fmi2Causality.output, description="wheel velocity [m/s] (flow)"))

    def exit_initialization_mode(self):
        self.x, self.v = self.x0, self.v0

    def _rhs(self, t, y):
        x, v = y
        r, dr = road(t, self.bump, self.bump_start, self.bump_length)
        return v, (self.F - self.k * (x - r) - self.d * (v - dr)) / self.m

    def do_step(self, current_time, step_size):
        self.x, self.v = rk4(self._rhs, current_time, (self.x, self.v), step_size, self.max_substep)
        return True
