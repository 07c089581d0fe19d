"""The compiled step of the UavStrategy FMU (uavsim/_strategy_ext.c) declared as an accelerator of
:meth:`uavsim.strategy.Strategy.step`, for the harness that checks every accelerator against its reference
(tests/accelerators/; the interface: master/accel.py, satisfied here structurally: code bundled into the FMUs
does not import the engine).

A case is a strategy in some situation and the FMU inputs of one step.  ``reference`` runs Strategy.step on a
copy and publishes as the FMU shell does; ``accelerated`` runs the compiled step on a copy and, where it declines,
the Python step, as the shell does.  Each returns the FMU's outputs and the whole final MissionState.

The situations are drawn around every decision of the step: fleets of targets with the three assignments and both
strategies, no zones, the paper's oblique zones, axis-aligned squares and random polygons, planning on and off,
positions on and about the arrival radius of targets, path and detour vertices and the base (down to the last bit
where Python's and libm's hypot disagree), groundspeeds about the 0.5 m/s brake threshold and drifting off the
leg (wind), battery on and about both thresholds, every mission state and phase, pending ground-station
commands, look-ahead segments near, into and out of zones, and whole flights from the pad (arrivals, photos,
battery returns, landings).
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

from . import native
from .strategy import OUTPUT_NAMES, Strategy, StrategyParams

# the paper area's zones and a few of its targets (ENU m), plus the scaling study's axis-aligned squares
PAPER_ZONES = [[(70.404, -147.896), (156.701, -38.700), (111.896, -3.197), (25.600, -112.404)],
               [(104.000, 167.097), (-2.695, 174.297), (-8.901, 82.498), (97.705, 75.198)],
               [(-75.197, -141.205), (-104.596, -1.195), (-194.096, -20.097), (-164.697, -159.996)]]
SQUARES = [[(255.0, 255.0), (345.0, 255.0), (345.0, 345.0), (255.0, 345.0)],
           [(-345.0, -345.0), (-255.0, -345.0), (-255.0, -255.0), (-345.0, -255.0)]]
PAPER_TARGETS = [(164.398, -276.305), (127.999, 275.398), (204.699, 176.597), (138.501, -139.601),
                 (-240.303, -92.795), (300.0, 200.0), (-16.997, 467.402), (30.404, -227.695)]
#: relative offsets from a threshold: on it, within rounding of it, just clear of it, well clear
NEAR = [0.0, 1e-16, -1e-16, 3e-16, -3e-16, 1e-13, -1e-13, 1e-12, -1e-12, 1e-9, -1e-9, 1e-3, -1e-3, 0.3, -0.3]
INPUTS = ("x", "y", "z", "vx", "vy", "phase", "consumed", "command")


@dataclass
class Case:
    strategy: Strategy
    t: float
    inputs: dict            # the FMU's inputs, by name (INPUTS)


class StrategyStep:
    name = "uavsim.strategy-step"
    replaces = "uavsim.strategy:Strategy.step"

    def load(self):
        if native.disabled():
            return None, f"{native.ENV} is set"
        # the library beside this package (an FMU's, built with it), else built here by the one build path
        ext = native.load_extension("_strategy_ext")
        return (ext, None) if ext is not None else native.build_extension("_strategy_ext")

    def cases(self, rng):
        for _ in range(40):
            strategy = _new_strategy(rng)
            for _ in range(30):
                yield _situation(rng, strategy)
        for planning in (True, False):
            strategy = _new_strategy(rng, zones=PAPER_ZONES, planning=planning)
            for _ in range(300):
                yield _near_zones(rng, strategy)
        yield from _hypot_disagreements(rng, 20)
        for _ in range(4):
            yield from _flight(rng, _new_strategy(rng, spread=250.0), 400)

    def reference(self, case: Case):
        strategy = _copy(case.strategy)
        i = case.inputs
        strategy.step(case.t, i["x"], i["y"], i["z"], i["vx"], i["vy"], i["phase"], i["consumed"], i["command"])
        return strategy.outputs(), strategy.mission

    def accelerated(self, impl, case: Case):
        strategy = _copy(case.strategy)
        # the FMU's variables as the shell holds them: the inputs, and the outputs published by the last step
        variables = dict(case.inputs, **dict(zip(OUTPUT_NAMES, strategy.outputs())))
        if impl.step(strategy.step_constants, strategy.mission, variables):
            return tuple(variables[name] for name in OUTPUT_NAMES), strategy.mission
        i = case.inputs
        strategy.step(case.t, i["x"], i["y"], i["z"], i["vx"], i["vy"], i["phase"], i["consumed"], i["command"])
        return strategy.outputs(), strategy.mission


STRATEGY_STEP = StrategyStep()


def _copy(strategy: Strategy) -> Strategy:
    return copy.deepcopy(strategy)        # the zone map is shared (it never changes)


def _polygon(rng):
    cx, cy, r = rng.uniform(-400, 400), rng.uniform(-400, 400), rng.uniform(20, 90)
    corners = ((-1, -1), (1, -1), (1.2, 0.5), (0, 1), (-1, 0.7)) if rng.random() < 0.5 else \
        ((-1, -1), (1, -1), (1, 1), (0.1, 0.1), (-1, 1))          # concave
    return [(cx + r * dx, cy + r * dy) for dx, dy in corners]


def _new_strategy(rng, zones=None, planning=None, spread=500.0) -> Strategy:
    if zones is None:
        zones = rng.choice([[], [], PAPER_ZONES, SQUARES, [_polygon(rng) for _ in range(rng.randrange(1, 4))]])
    n = rng.randrange(1, 13)
    targets = rng.sample(PAPER_TARGETS, min(n, len(PAPER_TARGETS))) if rng.random() < 0.4 else \
        [(rng.uniform(-spread, spread), rng.uniform(-spread, spread)) for _ in range(n)]
    count = rng.randrange(1, 4)
    return Strategy(StrategyParams(
        strategy=rng.choice("AB"), uav_index=rng.randrange(count), uav_count=count,
        assignment=rng.choice(["equal", "roundrobin", "spatial"]), targets=targets, zones=zones,
        zone_planning=rng.random() < 0.5 if planning is None else planning,
        arrival_radius=rng.choice([2.0, 2.0, 5.0, rng.uniform(0.5, 10.0)]),
        home_x=rng.choice([0.0, 3.0, rng.uniform(-50, 50)]), home_y=rng.choice([0.0, -4.0, rng.uniform(-50, 50)]),
        lookahead=rng.choice([2.0, 10.0, 30.0])))


def _around(rng, point, radius):
    """A position at radius * (1 + tiny) from point (on, just inside, just outside the arrival circle), or
    further away."""
    a = rng.uniform(0.0, 2.0 * math.pi)
    d = radius * (1.0 + rng.choice(NEAR)) if rng.random() < 0.7 else rng.uniform(0.0, 60.0)
    return point[0] + d * math.cos(a), point[1] + d * math.sin(a)


def _velocity(rng):
    """Still, about the 0.5 m/s threshold, slow or at cruise speed, in any direction (wind drift included)."""
    a = rng.uniform(0.0, 2.0 * math.pi)
    g = rng.choice([0.0, 0.5, 0.5 * (1 + rng.choice(NEAR)), rng.uniform(0.0, 1.0), rng.uniform(5.0, 12.0),
                    rng.uniform(5.0, 12.0)])
    return g * math.cos(a), g * math.sin(a)


def _waypoints(rng, zones, goal):
    """A path or detour: 0-3 vertices (off the zone corners, as planned, or anywhere), ending with the goal."""
    n = rng.choice([0, 1, 2, 2, 3])
    pts = []
    for _ in range(n - 1):
        if zones and rng.random() < 0.6:
            x, y = rng.choice(rng.choice(zones))
            pts.append((x + rng.uniform(-30.0, 30.0), y + rng.uniform(-30.0, 30.0)))
        else:
            pts.append((rng.uniform(-400.0, 400.0), rng.uniform(-400.0, 400.0)))
    return pts + [goal] if n else []


def _progress(rng, strategy, state):
    """A mission state with a consistent progress: the target flown to among those remaining."""
    m = strategy.mission
    m.state = state
    assigned = strategy.assigned
    m.remaining = [k for k in assigned if rng.random() < 0.6]
    m.visited = [k for k in assigned if k not in m.remaining]
    rng.shuffle(m.visited)
    m.current_target = rng.choice(m.remaining) if m.remaining and rng.random() < 0.9 else -1
    m.photo_count, m.avoid_count = len(m.visited), rng.randrange(5)
    m.plan_count, m.brake_count = rng.randrange(5), rng.randrange(3)
    m.last_photo_target = m.visited[-1] if m.visited else -1
    m.last_photo_time, m.last_photo_x, m.last_photo_y = rng.uniform(0, 900), rng.uniform(-99, 99), -0.0
    return strategy.targets[m.current_target] if state == 2 and m.current_target >= 0 else strategy.home


def _inputs(rng, x, y, vx, vy, strategy, command=None):
    p = strategy.p
    th = rng.choice([p.return_threshold, p.land_threshold])
    inputs = dict(x=x, y=y, z=rng.uniform(0.0, 30.0), vx=vx, vy=vy, phase=rng.choice([0, 1, 2, 2, 2, 2, 3, 4]),
                  consumed=rng.choice([0.1, 0.5, th, math.nextafter(th, 0.0), math.nextafter(th, 1.0), th + 0.01]),
                  command=rng.choice([0, 0, 0, 0, 1, 2]) if command is None else command)
    if rng.random() < 0.02:             # a number of another type: the compiled step leaves it to Python
        name = rng.choice(["x", "vy", "consumed"])
        inputs[name] = int(inputs[name])
    return inputs


def _situation(rng, strategy) -> Case:
    """The strategy in a random state around the step's decisions."""
    strategy = _copy(strategy)
    m = strategy.mission
    goal = _progress(rng, strategy, rng.choice([0, 1, 2, 2, 2, 3, 3, 4, 4, 5, 6, 7, 8, 9, 9, 10]))
    polys = strategy.zones.polys
    path = _waypoints(rng, polys and [list(z.exterior.coords) for z in polys], goal)
    if strategy.planning:
        m.path = path or [goal]
        m.path_goal = goal if rng.random() < 0.85 else rng.choice([None, (1.0, 2.0), strategy.home, list(goal)])
        m.braking = rng.random() < 0.15
        m.brake_point = (rng.uniform(-300, 300), rng.uniform(-300, 300))
    else:
        m.detour = path if rng.random() < 0.5 else []
    m.cmd = rng.choice([1, 2, 3])
    # where the UAV is: about what it flies to, its target, the base, a zone's corner, or anywhere
    refs = [goal, strategy.home, m.brake_point, m.path[0] if strategy.planning and m.path else (m.detour or [goal])[0]]
    if polys:
        refs.append(rng.choice(list(rng.choice(polys).exterior.coords)))
    x, y = _around(rng, rng.choice(refs), strategy.p.arrival_radius) if rng.random() < 0.9 else \
        (rng.uniform(-500, 500), rng.uniform(-500, 500))
    vx, vy = _velocity(rng)
    inputs = _inputs(rng, x, y, vx, vy, strategy)
    # the setpoint of the last step: often the waypoint flown to now (at the cruise altitude, or not)
    wp = tuple(m.path[0] if strategy.planning else (m.detour or [goal])[0])
    cruise = float(strategy.p.cruise_altitude)
    m.sp = rng.choice([wp + (cruise,), wp + (cruise,), wp + (inputs["z"],), (x, y, inputs["z"]), (0.0, 0.0, 1.0)])
    # a command taken before (the same one: nothing to take; a large int equal to it but another object)
    m.command_taken = rng.choice([0, 0, 0, 0, inputs["command"], inputs["command"] + 1000 - 1000])
    return Case(strategy, rng.uniform(0.0, 900.0), inputs)


def _near_zones(rng, strategy) -> Case:
    """Flying about the zones: segments whose boxes meet a zone's box, some crossing it, some not, some from
    inside it; the look-ahead and the leg to the next vertex."""
    strategy = _copy(strategy)
    m = strategy.mission
    x0, y0, x1, y1 = rng.choice(strategy.zones.polys).bounds
    x, y = rng.uniform(x0 - 40.0, x1 + 40.0), rng.uniform(y0 - 40.0, y1 + 40.0)
    goal = _progress(rng, strategy, rng.choice([2, 3, 4, 9]))
    vertex = (rng.uniform(x0 - 40.0, x1 + 40.0), rng.uniform(y0 - 40.0, y1 + 40.0))
    if strategy.planning:
        m.path, m.path_goal, m.braking = rng.choice([[goal], [vertex, goal]]), goal, False
    else:
        m.detour = rng.choice([[], [vertex, goal]])
    vx, vy = _velocity(rng)
    inputs = dict(x=x, y=y, z=20.0, vx=vx, vy=vy, phase=2, consumed=0.2, command=0)
    return Case(strategy, 1.0, inputs)


def _libm_hypot():
    """libm's hypot (what the compiled step calls), or None where ctypes cannot find it."""
    import ctypes
    import ctypes.util
    name = ctypes.util.find_library("m")
    if name is None:
        return None
    f = ctypes.CDLL(name).hypot
    f.restype, f.argtypes = ctypes.c_double, [ctypes.c_double, ctypes.c_double]
    return f


def _hypot_disagreements(rng, count):
    """An arrival radius exactly at Python's or at libm's distance where the two differ in the last bit (about 1
    position in 200): the compiled step must leave it to Python, which would otherwise miss or invent a photo,
    a waypoint or the base."""
    hypot = _libm_hypot()
    if hypot is None:
        return
    found = 0
    while found < count:
        ref = (rng.uniform(-300, 300), rng.uniform(-300, 300))
        p = (ref[0] + rng.uniform(-9.0, 9.0), ref[1] + rng.uniform(-9.0, 9.0))
        a, b = ref[0] - p[0], ref[1] - p[1]
        if math.hypot(a, b) == hypot(a, b):
            continue
        found += 1
        for radius in (math.hypot(a, b), hypot(a, b)):
            for at_target in (True, False):
                home = (0.0, 0.0) if at_target else ref
                strategy = Strategy(StrategyParams(targets=[ref, (500.0, 500.0)], arrival_radius=radius,
                                                   home_x=home[0], home_y=home[1]))
                m = strategy.mission
                m.state, m.current_target = (2, 0) if at_target else (3, -1)
                m.path, m.path_goal = [ref], ref
                yield Case(strategy, 1.0, dict(x=p[0], y=p[1], z=20.0, vx=7.0, vy=1.0, phase=2, consumed=0.2,
                                               command=0))


def _flight(rng, strategy, steps):
    """A whole flight from the pad, steps of 0.5 s, the vehicle flying to the setpoint at up to 10 m/s with a
    random drift (wind), its battery draining to the return threshold or not: the strategy before each step."""
    strategy = _copy(strategy)
    dt = 0.5
    drain = rng.choice([0.0005, 0.0005, 0.003])
    x, y = strategy.home
    wind = (rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0))
    for k in range(steps):
        m = strategy.mission
        dx, dy = m.sp[0] - x, m.sp[1] - y
        d = math.hypot(dx, dy)
        v = min(10.0, d / dt)
        vx, vy = (v * dx / d + wind[0], v * dy / d + wind[1]) if d > 0 and m.cmd == 2 else (0.0, 0.0)
        x, y = x + dt * vx, y + dt * vy
        phase = 0 if k < 3 else 1 if k < 6 else 4 if m.cmd == 3 and k % 7 == 0 else 2
        inputs = dict(x=x, y=y, z=20.0, vx=vx, vy=vy, phase=phase, consumed=min(1.0, drain * k),
                      command=2 if k == steps - 20 and rng.random() < 0.3 else 0)
        case = Case(_copy(strategy), dt * k, inputs)
        yield case
        strategy.step(case.t, x, y, 20.0, vx, vy, phase, inputs["consumed"], inputs["command"])
