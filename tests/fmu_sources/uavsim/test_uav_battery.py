"""UavBattery (uavsim.battery): Zeng et al. (2019) power and battery, against hand-derived values.

Hand computation (defaults): W = 1.5 * 9.80665 = 14.70998 N; A = 4 pi 0.127^2 = 0.202683 m^2;
2 rho A = 0.496573; v0 = sqrt(W / (2 rho A)) = 5.44270 m/s; Pi = 1.1 W v0 = 88.068 W;
s = 2 * 0.02 / (pi 0.127) = 0.100255; P0 = 0.012/8 * 1.225 * 0.100255 * 0.202683 * 86.4^3 = 24.082 W.
"""
import pytest

from uavsim.battery import (Battery, BatteryParams, PowerParams, current_for_power,
                            electrical_power, shaft_power)

P_HOVER_SHAFT = 24.082 + 88.068                 # 112.150 W
P_HOVER = P_HOVER_SHAFT / 0.6 + 5.0             # 191.917 W electrical
FLAT = dict(ocv_soc=(0.0, 1.0), ocv_cell=(3.7, 3.7), cell_resistance=0.0)   # 11.1 V ideal pack


def test_rotor_constants():
    p = PowerParams()
    assert p.v0 == pytest.approx(5.44270, rel=1e-4)
    assert p.pi == pytest.approx(88.068, rel=1e-4)
    assert p.p0 == pytest.approx(24.082, rel=1e-4)


def test_hover_power():
    p = PowerParams()
    assert shaft_power(0.0, p) == pytest.approx(P_HOVER_SHAFT, rel=1e-4)
    assert electrical_power(0.0, 0.0, True, p) == pytest.approx(P_HOVER, rel=1e-4)
    assert 180.0 <= P_HOVER <= 200.0            # Iris class: ~15-17 A at 11.1-12 V
    # on the ground (motors off) only the avionics draw power
    assert electrical_power(0.0, 0.0, False, p) == 5.0


def test_forward_flight_power_10ms():
    # V = 10: blade 24.082 (1 + 300/7464.96) = 25.050; induced: V^2/(2 v0^2) = 1.68788,
    # V^4/(4 v0^4) = 2.84888, sqrt(sqrt(3.84888) - 1.68788) = 0.52343 -> 46.097;
    # parasite 0.5 * 1.225 * 0.05 * 1000 = 30.625; total 101.772 W shaft, 174.62 W electrical
    p = PowerParams()
    assert shaft_power(10.0, p) == pytest.approx(101.772, rel=1e-4)
    assert electrical_power(10.0, 0.0, True, p) == pytest.approx(101.772 / 0.6 + 5, rel=1e-4)


def test_climb_power():
    # + m g vz / eta = 14.70998 * 2.5 / 0.6 = 61.29 W
    p = PowerParams()
    assert electrical_power(0, 2.5, True, p) - electrical_power(0, 0, True, p) == pytest.approx(61.29, rel=1e-3)


def test_current_from_power_with_resistance():
    # E = 12 V, R = 0.024 ohm, P = 192 W: I = (12 - sqrt(144 - 18.432)) / 0.048 = 16.546 A
    i, over = current_for_power(192.0, 12.0, 0.024)
    assert i == pytest.approx(16.546, rel=1e-4) and not over
    assert (12.0 - 0.024 * i) * i == pytest.approx(192.0, rel=1e-9)


def test_hover_endurance_ideal_pack():
    # flat 11.1 V, R = 0: I = 191.917 / 11.1 = 17.290 A; 5.1 Ah = 18360 C -> 1061.9 s = 17.70 min
    b = Battery(params=BatteryParams(**FLAT))
    t = 0.0
    while b.consumed < 1.0:
        b.step(1.0, 0.0, 0.0, 2)
        t += 1.0
    assert t == pytest.approx(18360 / (P_HOVER / 11.1), abs=1.0)


def test_hover_endurance_default_pack_in_published_range():
    # 3DR IRIS+ spec: 16-22 min.  Nominal estimate Q V_nom / P = 17.70 min (test above); the OCV
    # table averages slightly above 3.7 V/cell while I*R losses pull the other way: within 5 %.
    b = Battery()
    t = 0.0
    while b.consumed < 1.0:
        b.step(1.0, 0.0, 0.0, 2)
        t += 1.0
    minutes = t / 60
    assert 16.0 <= minutes <= 22.0
    assert minutes == pytest.approx(17.70, rel=0.05)
    assert b.voltage < 3 * 3.3                    # discharged pack


def test_cruise_distance_per_charge():
    # 10 m/s: 174.62 W / 11.1 V = 15.732 A -> 18360 / 15.732 = 1167.1 s -> 11.67 km
    b = Battery(params=BatteryParams(**FLAT))
    t = 0.0
    while b.consumed < 1.0:
        b.step(1.0, 10.0, 0.0, 2)
        t += 1.0
    assert t * 10.0 / 1000.0 == pytest.approx(11.67, abs=0.02)


def test_thresholds_consumed_time():
    # consumed reaches 0.8 after 0.8 * 1061.9 = 849.5 s of hover with the ideal pack
    b = Battery(params=BatteryParams(**FLAT))
    t = 0.0
    while b.consumed < 0.8:
        b.step(0.5, 0.0, 0.0, 2)
        t += 0.5
    assert t == pytest.approx(849.5, abs=0.6)
    assert b.soc == pytest.approx(1 - b.consumed)


def test_step_size_independence():
    a, c = Battery(), Battery()
    for _ in range(600):
        a.step(1.0, 7.0, 0.5, 2)
    for _ in range(12000):
        c.step(0.05, 7.0, 0.5, 2)
    assert a.consumed == pytest.approx(c.consumed, rel=1e-9)
    assert a.energy_used == pytest.approx(c.energy_used, rel=1e-9)


def test_fast_step_bit_identical_to_reference():
    # Battery.step (power computed once, the loop of uavsim.kernels) == step_reference, through every
    # regime: ground, hover, cruise, climb, overload (tiny pack), empty pack, odd step sizes (the compiled loop
    # is checked against the Python one by the accelerator harness, tests/accelerators/)
    import random

    from uavsim.kernels import Kernels
    rng = random.Random(2)
    for params in (BatteryParams(), BatteryParams(capacity_ah=0.05, initial_soc=0.3),
                   BatteryParams(cell_resistance=0.0), BatteryParams(cell_resistance=0.5)):
        a, b = Battery(params=params, kernels=Kernels(None)), Battery(params=params)
        for _ in range(3000):
            h = rng.choice([0.05, 0.1, 0.37, 1.0])
            args = (h, rng.uniform(0, 16), rng.uniform(-2, 3), rng.choice([0, 1, 2, 2, 3, 4]))
            out = a.step_outputs(*args)
            b.step_reference(*args)
            assert (a.charge_used, a.energy_used, a.current, a.voltage, a.power, a.overload) == \
                (b.charge_used, b.energy_used, b.current, b.voltage, b.power, b.overload)
            # what the FMU publishes: the reference model's properties
            assert out == (b.soc, b.consumed, b.voltage, b.current, b.power, b.energy_used, int(b.depleted))
        assert a.consumed > 0
