"""kernels.c skips two square roots of the flying sub-step where their rounded value cannot change the result (the
speed limit far from the goal, the unlimited change of the reference velocity): the compiled sub-step against the
Python twin (uavsim.kernels.fly_py, which takes every root), bit for bit, on states at and around both thresholds,
where a wrong margin would show."""
import math
import random
import struct

from uavsim import kernels as K


def params(speed, accel, pos_p):
    p = [0.0] * 15
    p[K.P_SPEED], p[K.P_ACCEL], p[K.P_POS_P], p[K.P_VEL_P], p[K.P_VEL_I] = speed, accel, pos_p, 2.0, 1.0
    p[K.P_ACCEL_Z], p[K.P_POS_Z_P], p[K.P_SPEED_UP], p[K.P_SPEED_DN] = 1.0, 1.0, 2.5, 1.5
    p[K.P_LAND_SPEED], p[K.P_LAND_ALT_LOW], p[K.P_TAKEOFF_ALT] = 0.5, 10.0, 20.0
    p[K.P_DRAG_K], p[K.P_AMAX] = 0.0204, 5.66
    return tuple(p)          # as Dynamics keeps them (the compiled twin converts each tuple once)


def flying(goal_x, goal_y, vt=(0.0, 0.0), vel=(0.0, 0.0), h=0.01):
    """One goto sub-step from (0, 0, 20) towards (goal_x, goal_y, 20)."""
    s = [0.0] * 27
    s[K.S_PZ], s[K.S_HOLDZ], s[K.S_PHASE], s[K.S_MODE] = 20.0, 20.0, 2, 1
    s[K.S_VX], s[K.S_VY] = vel
    s[K.S_VTX], s[K.S_VTY] = vt
    s[K.S_N], s[K.S_H], s[K.S_CMD] = 1, h, 2
    s[K.S_SPX], s[K.S_SPY], s[K.S_SPZ] = goal_x, goal_y, 20.0
    return s


def same_step(fly_c, s, p):
    a, b = list(s), list(s)
    fly_c(a, p)
    K.fly_py(b, p)
    return struct.pack("27d", *a) == struct.pack("27d", *b)


def around(x, rel=(0,), ulps=range(-40, 41)):
    """x moved by each of ulps units in the last place and by each relative amount of rel."""
    out = set()
    for u in ulps:
        y = x
        for _ in range(abs(u)):
            y = math.nextafter(y, math.inf if u > 0 else -math.inf)
        out.add(y)
    out.update(x * (1.0 + r) for r in rel)
    return sorted(out)


REL = [j * 2.0 ** -46 for j in range(-400, 401, 7)]


def test_speed_limit_shortcut_at_its_threshold(compiled_kernels):
    # goals at the distance where sqrt(2 accel (d - lin / 2)) crosses the speed limit, along an axis (d is the
    # distance itself) and in random directions; both sides of the threshold must occur
    fly_c = compiled_kernels.make_fly()
    rng = random.Random(2)
    below = above = 0
    for speed, accel, pos_p in [(10.0, 2.5, 1.0), (7.3, 1.9, 0.8), (12.5, 3.3, 1.7), (0.1, 2.5, 1.0)]:
        p = params(speed, accel, pos_p)
        lin = accel / (pos_p * pos_p)
        d0 = speed * speed / (2.0 * accel) + 0.5 * lin
        for d in around(d0, REL):
            angle = rng.uniform(0.0, 2.0 * math.pi)
            for goal in ((d, 0.0), (0.0, -d), (d * math.cos(angle), d * math.sin(angle))):
                assert same_step(fly_c, flying(*goal), p), (speed, accel, pos_p, goal)
            x = 2.0 * accel * (d - 0.5 * lin)
            below += math.sqrt(x) < speed
            above += math.sqrt(x) >= speed
    assert below > 100 and above > 100


def test_unlimited_change_shortcut_at_its_threshold(compiled_kernels):
    # at the goal (no desired velocity) the change of the reference velocity is -vt: magnitudes around the limit
    # accel * h, along an axis and in random directions, for several sub-steps
    fly_c = compiled_kernels.make_fly()
    rng = random.Random(3)
    limited = free = 0
    for h in (0.01, 0.0125, 0.05, 1.0 / 3.0):
        p = params(10.0, 2.5, 1.0)
        lim = 2.5 * h
        for r in around(lim, REL):
            angle = rng.uniform(0.0, 2.0 * math.pi)
            for vt in ((r, 0.0), (0.0, -r), (r * math.cos(angle), r * math.sin(angle))):
                assert same_step(fly_c, flying(0.0, 0.0, vt=vt, h=h), p), (h, vt)
                q = math.sqrt(vt[0] * vt[0] + vt[1] * vt[1])
                limited += q > lim
                free += q <= lim
    assert limited > 100 and free > 100


def test_shortcuts_with_odd_parameters(compiled_kernels):
    # a zero, negative or infinite speed limit, a zero or infinite acceleration (the thresholds' edge cases): still
    # the twin's steps
    fly_c = compiled_kernels.make_fly()
    rng = random.Random(4)
    for speed, accel in [(0.0, 2.5), (-0.0, 2.5), (-3.0, 2.5), (math.inf, 2.5), (10.0, 0.0),
                         (10.0, math.inf)]:
        p = params(speed, accel, 1.0)
        for _ in range(300):
            goal = (rng.uniform(-500.0, 500.0), rng.choice([0.0, rng.uniform(-500.0, 500.0)]))
            vt = (rng.uniform(-12.0, 12.0), rng.choice([0.0, -0.0, rng.uniform(-0.05, 0.05)]))
            assert same_step(fly_c, flying(*goal, vt=vt, vel=vt), p), (speed, accel, goal, vt)
    # a negative acceleration limit (a negative limit of the change: always limited), at the goal (elsewhere the
    # twin's square root of a negative number raises)
    p = params(10.0, -2.5, 1.0)
    for _ in range(300):
        vt = (rng.uniform(-12.0, 12.0), rng.choice([0.0, -0.0, rng.uniform(-0.05, 0.05)]))
        assert same_step(fly_c, flying(0.0, 0.0, vt=vt, vel=vt), p), vt
