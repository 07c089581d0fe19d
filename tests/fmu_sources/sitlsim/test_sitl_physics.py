"""The 6-DoF quadcopter of sitlsim (its reference, physics.step_py) against hand-derived expectations.  The compiled
step (physics.c) is checked against the reference by the accelerator harness (tests/accelerators/)."""
import math
import sys
from pathlib import Path

import pytest

from sitlsim import physics as ph
from sitlsim.iris import IrisParams
from sitlphys_helpers import thrust_pwm  # noqa: E402

G = 9.80665
RATE = 1200
DT = 1.0 / RATE


@pytest.fixture
def kernel():
    return ph.python()


def airborne(params=IrisParams(), altitude=50.0, rotor=0.0, pwm=1000.0, yaw=0.0):
    p = ph.kernel_params(params, RATE, yaw)
    s = ph.initial_state(p)
    s[ph.S_PD] = -altitude
    s[ph.S_GROUND] = 0.0
    for i in range(4):
        s[ph.S_M1 + i] = rotor
        s[ph.S_PWM1 + i] = pwm
    return s, p


def run(kernel, s, p, n):
    for _ in range(n):
        kernel.step(s, p)


def test_hover_thrust_equals_weight_at_the_documented_pwm(kernel):
    prm = IrisParams()
    # by hand: max thrust 5.84e-6 * 1100^2 = 7.0664 N; f = 1.5 * 9.80665 / 4 / 7.0664 = 0.520420;
    # 0.65 x^2 + 0.35 x = f -> x = 0.665181; a = 0.15 + 0.8 x = 0.682145 -> 1682.1 us (docs/sitl_physics.md)
    pwm = thrust_pwm(prm.mass * G / 4, prm)
    assert pwm == pytest.approx(1682.15, abs=0.01)
    assert prm.hover_pwm == pytest.approx(pwm, rel=1e-12)
    w_h = math.sqrt(prm.mass * G / 4 / prm.motor_constant)           # 793.54 rad/s
    s, p = airborne(prm, rotor=w_h, pwm=pwm)
    run(kernel, s, p, RATE)                                           # 1 s
    thrust = sum(prm.motor_constant * w * w for w in s[ph.S_M1:ph.S_M4 + 1])
    assert thrust == pytest.approx(prm.mass * G, rel=1e-12)
    assert abs(s[ph.S_VD]) < 1e-9 and abs(s[ph.S_PD] + 50.0) < 1e-9
    assert s[ph.S_FZ] == pytest.approx(-G, rel=1e-12)                # the IMU feels the thrust: -g
    # the Iris rotors sit asymmetrically (0.22 m front, 0.20 m back) but equal thrusts still give no
    # pitch torque (x positions are symmetric) and no roll torque from the two sides' cancelling pairs
    assert max(abs(v) for v in s[ph.S_RP:ph.S_RR + 1]) < 1e-12
    # electrical power at hover: the same propulsion model as UavBattery: 191.9 W (docs/uav_models.md)
    assert s[ph.S_POWER] == pytest.approx(191.9, abs=0.1)


def test_free_fall_follows_g_t2_over_2_with_zero_specific_force(kernel):
    s, p = airborne(IrisParams(flat_plate_area=0.0), altitude=100.0)   # no body drag; stopped rotors
    for k in range(1, 2 * RATE + 1):
        kernel.step(s, p)
        assert s[ph.S_FX] == s[ph.S_FY] == s[ph.S_FZ] == 0.0
    t = 2.0
    assert s[ph.S_VD] == pytest.approx(G * t, rel=1e-12)
    # semi-implicit Euler: fallen distance g dt^2 n(n+1)/2 = g t^2/2 + g t dt/2
    assert s[ph.S_PD] + 100.0 == pytest.approx(G * t * t / 2, abs=G * t * DT / 2 + 1e-9)
    assert s[ph.S_PD] + 100.0 > G * t * t / 2
    assert s[ph.S_PN] == s[ph.S_PE] == 0.0 and s[ph.S_GROUND] == 0.0


def test_yaw_torque_step_gives_the_hand_derived_angular_acceleration(kernel):
    prm = IrisParams(frame="+")            # symmetric arms: a yaw differential makes no roll/pitch torque
    w = prm.mass * G / 4
    dT = 0.5                                # N more on the CCW motors 1, 2, less on the CW motors 3, 4
    thrusts = (w + dT, w + dT, w - dT, w - dT)
    s, p = airborne(prm)
    for i, t in enumerate(thrusts):
        s[ph.S_PWM1 + i] = thrust_pwm(t, prm)
        s[ph.S_M1 + i] = math.sqrt(t / prm.motor_constant)     # already spun up: the step is in torque
    n = RATE // 2
    run(kernel, s, p, n)
    # tau_z = k_m (T1 + T2 - T3 - T4) = 0.06 * 4 * 0.5 = 0.12 N m; r_dot = tau_z / I_zz = 2.17293 rad/s^2
    r_dot = 0.06 * 4 * dT / 0.055225
    assert s[ph.S_RR] == pytest.approx(r_dot * n * DT, rel=1e-9)
    assert abs(s[ph.S_RP]) < 1e-12 and abs(s[ph.S_RQ]) < 1e-12
    yaw = 2 * math.atan2(s[ph.S_QZ], s[ph.S_QW])
    assert yaw == pytest.approx(0.5 * r_dot * (n * DT) ** 2, rel=2e-3)    # Euler: t^2/2 + O(t dt)
    assert abs(s[ph.S_VD]) < 1e-9                                          # total thrust still the weight


def test_motor_lag_is_first_order_with_the_spin_up_time_constant(kernel):
    prm = IrisParams()
    s, p = airborne(prm, pwm=2000.0)       # full throttle from stopped rotors
    n = round(prm.time_constant_up * RATE)                 # 15 frames = one time constant
    run(kernel, s, p, n)
    expect = prm.max_rot_velocity * (1 - math.exp(-n * DT / prm.time_constant_up))   # 63.2 %
    assert s[ph.S_M1] == pytest.approx(expect, rel=1e-12)


def test_resting_on_the_ground_neither_sinks_bounces_nor_tilts(kernel):
    prm = IrisParams()
    p = ph.kernel_params(prm, RATE, math.radians(30))
    s = ph.initial_state(p)
    below = thrust_pwm(0.8 * prm.mass * G / 4, prm)       # spinning, but less than the weight
    for k in range(RATE):
        # uneven motors: torques the landing gear has to take
        s[ph.S_PWM1:ph.S_PWM4 + 1] = [below + 40, below - 40, below, 1000.0 if k % 2 else below]
        kernel.step(s, p)
        assert s[ph.S_PN:ph.S_VD + 1] == [0.0] * 6
        assert s[ph.S_FX:ph.S_FZ + 1] == [0.0, 0.0, -G]
        assert s[ph.S_RP:ph.S_RR + 1] == [0.0] * 3 and s[ph.S_GROUND] == 1.0
    assert s[ph.S_QX] == s[ph.S_QY] == 0.0
    assert 2 * math.atan2(s[ph.S_QZ], s[ph.S_QW]) == pytest.approx(math.radians(30), abs=1e-12)


def test_full_throttle_lifts_off_the_ground(kernel):
    prm = IrisParams()
    p = ph.kernel_params(prm, RATE)
    s = ph.initial_state(p)
    s[ph.S_PWM1:ph.S_PWM4 + 1] = [2000.0] * 4
    run(kernel, s, p, RATE // 2)
    assert s[ph.S_GROUND] == 0.0 and s[ph.S_PD] < -0.5 and s[ph.S_VD] < 0


def test_wind_is_the_air_velocity_of_the_drag(kernel):
    # drifting with the wind there is no air speed, hence no drag; against still air the drag decelerates
    prm = IrisParams()
    w_h = math.sqrt(prm.mass * G / 4 / prm.motor_constant)
    for wind, expect_drag in ((5.0, False), (0.0, True)):
        s, p = airborne(prm, rotor=w_h, pwm=thrust_pwm(prm.mass * G / 4, prm))
        s[ph.S_VN] = 5.0
        s[ph.S_WN] = wind
        kernel.step(s, p)
        # rotor drag c * sum(w) * v + body drag 0.5 rho S v^2, per unit mass
        drag = (prm.rotor_drag * 4 * w_h * 5.0 + 0.5 * prm.rho * prm.flat_plate_area * 25.0) / prm.mass
        assert s[ph.S_FX] == pytest.approx(-drag if expect_drag else 0.0, rel=1e-6, abs=1e-12)
