"""Reference solutions of the quarter-car benchmarks (``--reference analytic:ssp/coupling/quarter_car_exact.py:
linear``): the monolithic system solved by scipy's DOP853 at rtol 1e-12, atol 1e-14 (its own error is below 1e-9
of the signals, far under any coupling error measured on it), as functions of time returning the signals by their
'component.variable' names. The parameter sets here are the ones fmu_sources/coupling/build.py writes into the SSPs
(Sadjina et al. 2017's quarter car: chassis 400 kg on 15 kN/m and 1 kN s/m, wheel 40 kg on a 150 kN/m tyre).

Chassis (deflection z = x_C - x_W, velocity v_C) and wheel (x_W, v_W) as one ODE, the wheel over a cosine bump r(t):

    z' = v_C - v_W,   m_C v_C' = -F,   m_W v_W' = F - k_W (x_W - r) - d_W (v_W - r'),   x_W' = v_W
    F = k_C z + d (v_C - v_W) + d2 (v_C - v_W) |v_C - v_W|
"""
import math

import numpy as np

CHASSIS = dict(m=400.0, k=15000.0, d=1000.0, d2=0.0, z0=0.0, v0=0.0)
WHEEL = dict(m=40.0, k=150000.0, d=0.0, bump=0.05, bump_start=0.5, bump_length=0.2, x0=0.0, v0=0.0)
NONLINEAR_CHASSIS = dict(CHASSIS, d2=2000.0)
STOP = 5.0


def _road(t, height, start, length):
    if not (start <= t <= start + length):
        return 0.0, 0.0
    phase = 2.0 * math.pi * (t - start) / length
    return height * (1.0 - math.cos(phase)) / 2.0, height * math.pi / length * math.sin(phase)


def _solve(chassis, wheel, t):
    from scipy.integrate import solve_ivp
    c, w = chassis, wheel

    def rhs(time, y):
        z, vc, xw, vw = y
        dv = vc - vw
        force = c["k"] * z + c["d"] * dv + c["d2"] * dv * abs(dv)
        r, dr = _road(time, w["bump"], w["bump_start"], w["bump_length"])
        return [dv, -force / c["m"], vw, (force - w["k"] * (xw - r) - w["d"] * (vw - dr)) / w["m"]]

    t = np.atleast_1d(np.asarray(t, dtype=float))
    # the bump's start and end are kinks of the road: integrate piecewise so the solver never steps across one
    edges = sorted({0.0, w["bump_start"], w["bump_start"] + w["bump_length"], max(float(t.max()), 0.0)})
    y = [c["z0"], c["v0"], w["x0"], w["v0"]]
    out = np.empty((4, len(t)))
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (t >= a) & (t <= b)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
        if inside.any():
            out[:, inside] = sol.sol(t[inside])
        y = sol.y[:, -1]
    if (t == 0.0).any():
        out[:, t == 0.0] = np.array([c["z0"], c["v0"], w["x0"], w["v0"]])[:, None]
    z, vc, xw, vw = out
    dv = vc - vw
    force = c["k"] * z + c["d"] * dv + c["d2"] * dv * np.abs(dv)
    return {"chassis.z": z, "chassis.v": vc, "chassis.F": force, "wheel.x": xw, "wheel.v": vw}


def linear(t):
    """quarter_car_linear.ssp: linear suspension damping."""
    return _solve(CHASSIS, WHEEL, t)


def nonlinear(t):
    """quarter_car_nonlinear.ssp: progressive damping d2 = 2000 N s^2/m^2."""
    return _solve(NONLINEAR_CHASSIS, WHEEL, t)
