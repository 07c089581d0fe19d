"""UavDynamics physics (uavsim.dynamics) against hand-derived values.

Default parameters (uavsim/params.py): m = 1.5 kg, S_FP = 0.05 m^2, rho = 1.225 kg/m^3,
theta_max = 30 deg, V = 10 m/s, A = 2.5 m/s^2, K_pos = 1 /s, climb 2.5 m/s, descent 1.5 m/s,
A_z = 1 m/s^2, land 0.5 m/s below 10 m, preflight 5 s, takeoff altitude 20 m, g = 9.80665.
"""
import math

import pytest

from uavsim.dynamics import FLY, LANDED, Dynamics, DynamicsParams, sqrt_controller

G = 9.80665
K = 0.5 * 1.225 * 0.05 / 1.5          # drag coefficient rho S_FP / (2m) = 0.0204167 1/m


def airborne(**kw):
    """Vehicle hovering at 20 m over (0, 0) after takeoff + 3 s settling."""
    d = Dynamics(DynamicsParams(**kw))
    while d.phase != FLY:
        d.step(0.1, 1)
    d.step(3.0, 1)
    return d


def test_sqrt_controller_hand_values():
    # p = 1, a = 2.5: linear within a/p^2 = 2.5 m; beyond, sqrt(2 a (d - 1.25))
    assert sqrt_controller(1.0, 1.0, 2.5) == pytest.approx(1.0)
    assert sqrt_controller(21.25, 1.0, 2.5) == pytest.approx(10.0)     # sqrt(5 * 20) = 10
    assert sqrt_controller(0.0, 1.0, 2.5) == 0.0


def test_takeoff_time():
    # preflight 5 s; climb: ramp 0 -> 2.5 m/s at 1 m/s^2 = 2.5 s (3.125 m); braking curve
    # sqrt(2*1*(e - 0.5)) reaches 2.5 m/s at e = 3.625 m; cruise 20 - 3.125 - 3.625 = 13.25 m
    # at 2.5 m/s = 5.3 s; braking 3.625 -> 1 m: [sqrt(2(e-0.5))] = 2.5 - 1 = 1.5 s; linear
    # 1 m -> 0.2 m (takeoff complete at alt - 0.2 m): ln(1/0.2) = 1.609 s.
    # total 5 + 2.5 + 5.3 + 1.5 + 1.609 = 15.91 s
    d = Dynamics()
    t = 0.0
    while d.phase != FLY:
        d.step(0.01, 1)
        t += 0.01
    assert t == pytest.approx(15.91, abs=0.1)


def test_no_takeoff_before_preflight_done():
    d = Dynamics()
    d.step(4.9, 1)
    assert d.phase == 0 and d.pos[2] == 0.0
    d.step(0.2, 1)
    assert d.phase == 1


def test_settle_time_100m_leg_and_no_overshoot():
    # trapezoid with sqrt braking: accelerate 0 -> 10 m/s in v/a = 4 s (20 m); braking curve
    # reaches 10 m/s at e = 21.25 m; cruise 100 - 20 - 21.25 = 58.75 m in 5.875 s; sqrt braking
    # 21.25 -> 2.5 m: (2/5)(10 - 2.5) = 3 s; linear 2.5 -> 0.5 m: ln 5 = 1.609 s.
    # within 0.5 m after 4 + 5.875 + 3 + 1.609 = 14.48 s (rule of thumb d/v + v/a = 14 s)
    d = airborne()
    t, t_arr, xmax = 0.0, None, -1e9
    for _ in range(600):
        d.step(0.05, 2, (100.0, 0.0, 20.0))
        t += 0.05
        xmax = max(xmax, d.pos[0])
        if t_arr is None and math.hypot(100.0 - d.pos[0], d.pos[1]) < 0.5:
            t_arr = t
    assert t_arr == pytest.approx(14.48, abs=0.3)
    assert xmax - 100.0 < 0.05          # no overshoot
    assert d.pos[0] == pytest.approx(100.0, abs=0.01)


def test_cruise_speed_and_still_air_tilt():
    # at 10 m/s in still air: drag accel K V^2 = 2.0417 m/s^2 -> tilt atan(2.0417/g) = 11.76 deg
    d = airborne()
    d.step(10.0, 2, (1000.0, 0.0, 20.0))
    assert d.groundspeed == pytest.approx(10.0, abs=1e-3)
    assert d.tilt_deg == pytest.approx(math.degrees(math.atan(K * 100 / G)), abs=0.05)


def test_hold_in_wind_below_limit_zero_offset_and_tilt():
    # W = 8 m/s from the east (air velocity -8 m/s): the integrator removes the offset; the
    # equilibrium lean angle is atan(K W^2 / g) = atan(1.30667 / 9.80665) = 7.5896 deg
    d = airborne()
    xs = []
    for _ in range(600):
        d.step(0.1, 0, wind=(-8.0, 0.0, 0.0))
        xs.append(d.pos[0])
    assert abs(d.pos[0]) < 0.01 and abs(d.pos[1]) < 1e-9
    assert d.tilt_deg == pytest.approx(7.5896, abs=0.01)
    assert d.airspeed == pytest.approx(8.0, abs=1e-3)
    assert -1.0 < min(xs) < 0.0        # transient push to the west, recovered


def test_max_wind_held_and_drift_beyond():
    # W_max = sqrt(g tan30 / K) = sqrt(5.66189 / 0.0204167) = 16.653 m/s
    p = DynamicsParams()
    assert p.max_wind_hold == pytest.approx(16.653, abs=0.01)
    # in 20 m/s wind at full lean the airspeed settles at W_max: drift = -(20 - 16.653) m/s
    d = airborne()
    d.step(60.0, 0, wind=(-20.0, 0.0, 0.0))
    assert d.vel[0] == pytest.approx(-(20.0 - 16.653), abs=0.01)
    assert d.tilt_deg == pytest.approx(30.0, abs=1e-6)


def test_landing_time_and_landed():
    # from 20 m: ramp to 1.5 m/s (1.5 s, 1.125 m), (10 - 1.125)/1.5 = 5.917 s to 10 m, then
    # slowing to 0.5 m/s (1 s, 1.0 m) and 9.0 / 0.5 = 18 s: total 26.42 s
    d = airborne()
    z0 = d.pos[2]
    assert z0 == pytest.approx(20.0, abs=0.01)
    t = 0.0
    while d.phase != LANDED:
        d.step(0.01, 3)
        t += 0.01
        assert t < 60
    assert t == pytest.approx(26.42, abs=0.15)
    assert d.pos[2] == 0.0 and d.vel == [0.0, 0.0, 0.0]


def test_master_step_independence():
    # identical inputs held over the master step + fixed 0.01 s sub-steps: the trajectory at
    # master step 0.05 s and 1 s must agree; tolerance 1e-6 m (measured: bit-identical)
    def run(h):
        d = Dynamics()
        out, t, n = [], 0.0, int(round(60 / h))
        for i in range(n):
            cmd = 1 if i * h < 12 else 2
            d.step(h, cmd, (80.0, -40.0, 30.0), (-5.0, 1.0, 0.0))
            if abs((i + 1) * h - round((i + 1) * h)) < 1e-9:
                out.append(tuple(d.pos) + tuple(d.vel))
        return out
    a, b = run(0.05), run(1.0)
    assert len(a) == len(b) == 60
    assert max(abs(u - v) for ra, rb in zip(a, b) for u, v in zip(ra, rb)) < 1e-6


def test_fast_loop_bit_identical_to_reference_substeps():
    # Dynamics.step runs the flying sub-steps in the loop of uavsim.kernels; over a whole flight with every phase
    # (preflight, takeoff, goto legs, hold, gusty wind, landing, landed, re-takeoff) and several master steps it
    # must give exactly the reference sub-step results (the compiled loop is checked against the Python one by
    # the accelerator harness, tests/accelerators/)
    import random

    from uavsim.kernels import Kernels
    rng = random.Random(5)
    script = []
    t = 0.0
    while t < 140.0:
        h = rng.choice([0.01, 0.05, 0.1, 0.37, 1.0])
        if t < 3:
            cmd = 0
        elif t < 20:
            cmd = 1
        elif t < 80:
            cmd = 2 if (t // 7) % 3 else 0
        elif t < 120:
            cmd = 3
        else:
            cmd = 1
        sp = ((t // 15) * 37.0 - 60.0, 80.0 - (t // 11) * 29.0, 20.0 + (t // 20) * 3)
        wind = (rng.uniform(-11, 3), rng.uniform(-4, 4), rng.uniform(-1, 1))
        script.append((h, cmd, sp, wind))
        t += h
    a, b = Dynamics(kernels=Kernels(None)), Dynamics()
    phases = set()
    for h, cmd, sp, wind in script:
        a.step(h, cmd, sp, wind)
        b.step_reference(h, cmd, sp, wind)
        assert (a.pos, a.vel, a.vt, a.vtz, a.integ, a.a_cmd, a.phase, a.mode, a.hold, a.hold_z, a.ready) == \
            (b.pos, b.vel, b.vt, b.vtz, b.integ, b.a_cmd, b.phase, b.mode, b.hold, b.hold_z, b.ready)
        phases.add(a.phase)
    assert phases == {0, 1, 2, 3, 4}


@pytest.mark.parametrize("push", [False, True])
def test_outputs_are_the_published_properties(push):
    # Dynamics.outputs() (one call per FMU step) gives exactly the properties the FMU used to read one by one,
    # through takeoff, flight in wind, landing and on the ground
    m = Dynamics(DynamicsParams(wind_push=push))
    seen = set()
    for k in range(1500):
        cmd = 1 if k < 150 else (2 if k < 600 else 3)
        m.step(0.1, cmd, (40.0, -25.0, 30.0), (3.0 * math.sin(0.01 * k), -2.0, 0.0))
        o = m.outputs()
        gv = m.ground_velocity
        assert o == (*m.pos, *gv, m.airspeed, m.groundspeed, m.tilt_deg, int(m.phase), int(m.ready))
        seen.add(m.phase)
    assert {FLY, LANDED} <= seen
