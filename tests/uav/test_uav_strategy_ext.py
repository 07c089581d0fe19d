"""The compiled fast path of the UavStrategy FMU's step (uavsim/_strategy_ext.c) against the Python step.

On every random state the extension either does the step -- and then the shell's outputs and the model's
attributes are bit for bit what the Python step gives from the same state -- or declines it having changed
nothing (every attribute of the shell and the model the same object, every list the same items).  The states
are drawn around the decisions of Strategy.step: positions on and near the arrival radius of targets, path and
detour vertices and the base, speeds about the 0.5 m/s brake and look-ahead threshold, battery on and about
both thresholds, every mission state and phase, planning on and off, strategies A and B, pending commands,
look-ahead segments ending at and inside zones.
"""
from __future__ import annotations

import copy
import importlib.util
import math
import os
import random
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from build_script import SRC

from uavsim import mission_encoding as M
from uavsim import native
from uavsim.fmi import _NOT_STATE
from uavsim.strategy import StrategyParams

ROOT = SRC.parent
# the paper area's zones and a few of its targets (ENU m), plus the scaling study's axis-aligned squares
PAPER_ZONES = [[(70.404, -147.896), (156.701, -38.700), (111.896, -3.197), (25.600, -112.404)],
               [(104.000, 167.097), (-2.695, 174.297), (-8.901, 82.498), (97.705, 75.198)],
               [(-75.197, -141.205), (-104.596, -1.195), (-194.096, -20.097), (-164.697, -159.996)]]
SQUARES = [[(255.0, 255.0), (345.0, 255.0), (345.0, 345.0), (255.0, 345.0)],
           [(-345.0, -345.0), (-255.0, -345.0), (-255.0, -255.0), (-345.0, -255.0)]]
TARGETS = [(164.398, -276.305), (127.999, 275.398), (204.699, 176.597), (138.501, -139.601),
           (-240.303, -92.795), (300.0, 200.0), (-16.997, 467.402), (30.404, -227.695)]
ZONE_SETS = {"none": [], "paper": PAPER_ZONES, "squares": SQUARES}
NEAR = [0.0, 1e-16, -1e-16, 3e-16, -3e-16, 1e-13, -1e-13, 1e-12, -1e-12, 1e-9, -1e-9, 1e-3, -1e-3, 0.3, -0.3]


@pytest.fixture(scope="module")
def ext(extensions_folder):
    """The extension compiled here as build_fmus.py compiles it for the FMUs."""
    module = native.load_extension("_strategy_ext", extensions_folder)
    if module is None:
        pytest.skip("UAVSIM_PURE_PYTHON is set or the extension does not load")
    return module


@pytest.fixture(scope="module")
def shell_module():
    """A private copy of the shell's module, whose Python path the test runs (its _FAST_STEP off)."""
    spec = importlib.util.spec_from_file_location("strategy_ext_shell", SRC / "UavStrategy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod._FAST_STEP = None
    return mod


def _new_shell(mod, zones, planning, kind, uav_index=0, arrival=2.0):
    s = mod.UavStrategy(instance_name="t", resources=str(SRC), visible=False)
    s.targets = ";".join(f"{x!r},{y!r}" for x, y in TARGETS)
    s.zones = "|".join(";".join(f"{x!r},{y!r}" for x, y in z) for z in zones)
    s.n_targets = s.n_zones = -1
    s.zone_planning, s.strategy, s.uav_index, s.uav_count = planning, kind, uav_index, 2
    s.arrival_radius, s.home_x, s.home_y = arrival, 3.0, -4.0
    s.exit_initialization_mode()
    return s


def _bits(v):
    """A value with every float replaced by its bit pattern (so -0.0 != 0.0 and NaN == NaN), types kept."""
    if isinstance(v, float):
        return ("f", type(v), struct.pack("<d", v))
    if isinstance(v, (list, tuple)):
        return (type(v), tuple(_bits(x) for x in v))
    if isinstance(v, dict):
        return (dict, tuple((k, _bits(x)) for k, x in v.items()))
    if v is None or isinstance(v, (bool, int, str, bytes)):
        return (type(v), v)
    return ("obj", type(v))


#: the mission's indexed parameters (hundreds of shell attributes): checked once per test, not at every case
MISSION = frozenset(n for n, _ in M.parameter_names())


def _state_of(shell) -> dict:
    """Everything a step may change: the shell's variables and the model's attributes (not the zone geometry,
    which only planning touches and both copies share)."""
    out = {k: _bits(v) for k, v in shell.__dict__.items()
           if k != "_model" and k not in _NOT_STATE and k not in MISSION}
    model = shell.__dict__["_model"]
    out.update({("model", k): _bits(v) for k, v in model.__dict__.items() if k not in ("zones", "p")})
    return out


def _identity_of(shell):
    """The objects the shell and its model hold, and the items of their lists: a declined step keeps them all."""
    def snap(d):
        return {k: (id(v), tuple(map(id, v)) if isinstance(v, list) else None)
                for k, v in d.items() if k not in MISSION}
    return snap(shell.__dict__), snap(shell.__dict__["_model"].__dict__)


def _twin(shell):
    """A copy of the shell (its variables are immutable values) and of its model sharing the zone geometry."""
    model = shell.__dict__["_model"]
    twin = copy.copy(shell)
    twin.__dict__ = dict(shell.__dict__)
    twin._model = copy.deepcopy(model, {id(model.zones): model.zones, id(model.p): model.p})
    return twin


def _around(rng, point, radius):
    """A position at radius * (1 + tiny) from point (on, just inside, just outside the arrival circle), or
    further away."""
    a = rng.uniform(0.0, 2.0 * math.pi)
    d = radius * (1.0 + rng.choice(NEAR)) if rng.random() < 0.7 else rng.uniform(0.0, 60.0)
    return point[0] + d * math.cos(a), point[1] + d * math.sin(a)


def _velocity(rng):
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


def _randomize(rng, shell):
    """A random state of the shell and its model around the step's decisions."""
    m = shell._model
    p = m.p
    m.state = rng.choice([0, 1, 2, 2, 2, 3, 3, 4, 4, 5, 6, 7, 8, 9, 9, 10])
    m.current_target = rng.choice([-1] + m.assigned * 3) if m.assigned else -1
    goal = m.targets[m.current_target] if m.state == 2 and m.current_target >= 0 else m.home
    path = _waypoints(rng, m.zones.polys and [list(z.exterior.coords) for z in m.zones.polys], goal)
    if m.planning:
        m.path = path or [goal]
        m.path_goal = goal if rng.random() < 0.85 else rng.choice([None, (1.0, 2.0), m.home])
        m.braking = rng.random() < 0.15
        m.brake_point = (rng.uniform(-300, 300), rng.uniform(-300, 300))
    else:
        m.detour = path if rng.random() < 0.5 else []
    m.cmd = rng.choice([1, 2, 3])
    m.photo_count, m.avoid_count = rng.randrange(5), rng.randrange(5)
    m.last_photo_target = rng.choice([-1, 0, 3])
    m.last_photo_time, m.last_photo_x, m.last_photo_y = rng.uniform(0, 900), rng.uniform(-99, 99), -0.0
    # where the UAV is: about what it flies to, its target, the base, a zone's corner, or anywhere
    refs = [goal, m.home, m.brake_point, m.path[0] if m.planning else (m.detour or [goal])[0]]
    if m.zones.polys:
        refs.append(rng.choice(list(rng.choice(m.zones.polys).exterior.coords)))
    shell.x, shell.y = _around(rng, rng.choice(refs), p.arrival_radius) if rng.random() < 0.9 else \
        (rng.uniform(-500, 500), rng.uniform(-500, 500))
    shell.z = rng.uniform(0.0, 30.0)
    shell.vx, shell.vy = _velocity(rng)
    # the setpoint of the last step: often the waypoint flown to now (at the cruise altitude, or not)
    wp = tuple(m.path[0] if m.planning else (m.detour or [goal])[0])
    m.sp = rng.choice([wp + (float(p.cruise_altitude),), wp + (float(p.cruise_altitude),), wp + (shell.z,),
                       (shell.x, shell.y, shell.z), (0.0, 0.0, 1.0)])
    shell.phase = rng.choice([0, 1, 2, 2, 2, 2, 3, 4])
    th = rng.choice([p.return_threshold, p.land_threshold])
    shell.consumed = rng.choice([0.1, 0.5, th, math.nextafter(th, 0.0), math.nextafter(th, 1.0), th + 0.01])
    shell.command = rng.choice([0, 0, 0, 0, 1, 2])
    shell._command_taken = rng.choice([0, 0, 0, 0, shell.command])
    shell._publish()        # the invariant of every step: outputs == model.outputs()


@pytest.mark.parametrize("zones", sorted(ZONE_SETS))
@pytest.mark.parametrize("planning", [True, False])
@pytest.mark.parametrize("kind", ["A", "B"])
def test_fast_path_does_the_python_step_or_nothing(ext, shell_module, zones, planning, kind):
    rng = random.Random(f"{zones}{planning}{kind}")
    shell = _new_shell(shell_module, ZONE_SETS[zones], planning, kind, uav_index=1)
    handled = declined = 0
    mission = {k: shell.__dict__[k] for k in MISSION}
    ext.reset_stats()
    for i in range(1500):
        _randomize(rng, shell)
        twin = _twin(shell)
        before, ident = _state_of(shell), _identity_of(shell)
        if ext.step(shell.__dict__):
            handled += 1
            twin.do_step(0.1 * i, 0.1)           # the Python step (the module's fast path is off)
            assert _state_of(shell) == _state_of(twin), f"case {i}"
        else:
            declined += 1
            assert _identity_of(shell) == ident and _state_of(shell) == before, f"case {i}"
    assert all(shell.__dict__[k] is v for k, v in mission.items())
    # both branches exercised on a fair share of the cases, and segments near zones told clear by their edges
    assert handled > 300 and declined > 300, (handled, declined)
    assert zones != "paper" or ext.stats()["edge_clears"] > 30, ext.stats()


def _check_step(ext, shell, t):
    """One step both ways from the same state: the extension's result or no trace of it; True when it did it."""
    twin, before, ident = _twin(shell), _state_of(shell), _identity_of(shell)
    if ext.step(shell.__dict__):
        twin.do_step(t, 0.1)
        assert _state_of(shell) == _state_of(twin)
        return True
    assert _identity_of(shell) == ident and _state_of(shell) == before
    return False


@pytest.mark.parametrize("planning", [True, False])
def test_fast_path_near_zones(ext, shell_module, planning):
    """Flying about the paper's (oblique) zones: segments whose boxes meet a zone's box, some crossing it, some
    not, some from inside it; the look-ahead and the leg to the next vertex."""
    rng = random.Random(planning)
    shell = _new_shell(shell_module, PAPER_ZONES, planning, "A", arrival=rng.choice([2.0, 5.0]))
    m = shell._model
    polys = m.zones.polys
    shell.phase, shell.consumed, shell.command, shell._command_taken = 2, 0.2, 0, 0
    ext.reset_stats()
    handled = 0
    for i in range(2000):
        x0, y0, x1, y1 = rng.choice(polys).bounds
        shell.x, shell.y = rng.uniform(x0 - 40.0, x1 + 40.0), rng.uniform(y0 - 40.0, y1 + 40.0)
        shell.vx, shell.vy = _velocity(rng)
        m.state = rng.choice([2, 3, 4, 9])
        m.current_target = rng.choice(m.assigned)
        goal = m.targets[m.current_target] if m.state == 2 else m.home
        vertex = (rng.uniform(x0 - 40.0, x1 + 40.0), rng.uniform(y0 - 40.0, y1 + 40.0))
        if planning:
            m.path, m.path_goal, m.braking = rng.choice([[goal], [vertex, goal]]), goal, False
        else:
            m.detour = rng.choice([[], [vertex, goal]])
        shell._publish()
        handled += _check_step(ext, shell, 0.1 * i)
    stats = ext.stats()
    assert handled > 400 and stats["zone"] > 300 and stats["edge_clears"] > 200, stats


def _libm_hypot():
    """libm's hypot (what the extension calls), or None where ctypes cannot find it."""
    import ctypes
    import ctypes.util
    name = ctypes.util.find_library("m")
    if name is None:
        return None
    f = ctypes.CDLL(name).hypot
    f.restype, f.argtypes = ctypes.c_double, [ctypes.c_double, ctypes.c_double]
    return f


def _disagreements(hypot, ref, count, rng):
    """Positions p about ref where libm's hypot of ref - p differs from math.hypot's (about 1 in 200 do): the
    distance each gives."""
    out = []
    while len(out) < count:
        p = (ref[0] + rng.uniform(-9.0, 9.0), ref[1] + rng.uniform(-9.0, 9.0))
        a, b = ref[0] - p[0], ref[1] - p[1]
        if math.hypot(a, b) != hypot(a, b):
            out.append((p, math.hypot(a, b), hypot(a, b)))
    return out


def test_hypot_disagreements_at_a_threshold_are_left_to_python(ext, shell_module):
    """An arrival radius exactly between Python's and libm's distance (the two hypot implementations differ in
    the last bit now and then): the extension must not decide with its own, which would miss or invent a photo,
    a waypoint or the base."""
    hypot = _libm_hypot()
    if hypot is None:
        pytest.skip("libm not found")
    rng = random.Random(5)
    shell = _new_shell(shell_module, [], True, "A")
    m = shell._model
    shell.phase, shell.consumed, shell.command, shell._command_taken, shell.vx, shell.vy = 2, 0.2, 0, 0, 7.0, 1.0
    cases = 0
    for state, ref in ((2, m.targets[m.assigned[0]]), (3, m.home)):
        for p, py, c in _disagreements(hypot, ref, 40, rng):
            for radius in (py, c):                  # on Python's side, then on libm's side of the threshold
                m.p.arrival_radius = radius
                m._fast_consts = m._native_consts()
                m.state, m.current_target = state, m.assigned[0] if state == 2 else -1
                m.path, m.path_goal = [ref], ref
                shell.x, shell.y = p
                shell._publish()
                assert not _check_step(ext, shell, 1.0)
                cases += 1
    assert cases == 160


def test_fast_path_takes_the_common_steps(ext, shell_module):
    """En route, well away from every threshold and zone, in each flying state; on the ground, landing."""
    shell = _new_shell(shell_module, SQUARES, True, "A")
    m = shell._model
    shell.phase, shell.consumed, shell.vx, shell.vy = 2, 0.3, 7.0, 7.0
    assert not ext.step(shell.__dict__)          # takeoff -> transit: Python starts the first leg
    shell_module.UavStrategy.do_step(shell, 0.0, 0.1)
    assert m.state == 2 and m.path_goal == m.targets[m.current_target]
    shell.x, shell.y = 20.0, 20.0
    for state in (2, 3, 4, 9):
        m.state = state
        shell_module.UavStrategy.do_step(shell, 0.1, 0.1)      # plans the leg when the goal changed
        ext.reset_stats()
        assert ext.step(shell.__dict__), ext.stats()
        assert shell.cmd == 2 and (shell.sp_x, shell.sp_y) == m.path[0] and shell.mission_state == state
    for state, phase, cmd in ((7, 4, 3), (8, 0, 3), (5, 3, 3), (0, 0, 1), (1, 1, 1)):
        m.state, shell.phase = state, phase
        assert ext.step(shell.__dict__) and shell.cmd == cmd and m.cmd == cmd


def test_fast_path_declines_a_zone_ahead(ext, shell_module):
    """A look-ahead ending inside a zone's box is Python's to test (it brakes here)."""
    shell = _new_shell(shell_module, SQUARES, True, "A")
    m = shell._model
    shell.phase, shell.consumed = 2, 0.3
    shell_module.UavStrategy.do_step(shell, 0.0, 0.1)
    m.state, m.path, m.path_goal, m.braking = 3, [m.home], m.home, False
    shell.x, shell.y, shell.vx, shell.vy = 240.0, 300.0, 10.0, 0.0      # 15 m west of a square, flying east
    ext.reset_stats()
    assert not ext.step(shell.__dict__) and ext.stats()["zone"] == 1
    shell_module.UavStrategy.do_step(shell, 0.1, 0.1)
    assert m.braking and shell.avoiding == 1


def _fly(shell, steps, t0, inputs=None):
    """Steps of the shell with a vehicle flying to its setpoint at 10 m/s (or the given inputs): the inputs and
    the outputs of each step."""
    seen, outs = [], []
    for k in range(steps):
        if inputs is None:
            dx, dy = shell.sp_x - shell.x, shell.sp_y - shell.y
            d = math.hypot(dx, dy)
            v = min(10.0, d / 0.1)
            vx, vy = (v * dx / d, v * dy / d) if d > 0 else (0.0, 0.0)
            step = dict(x=shell.x + 0.1 * vx, y=shell.y + 0.1 * vy, vx=vx, vy=vy, z=20.0,
                        phase=2 if shell.cmd == 2 or k > 0 else 1, consumed=0.001 * (t0 + k) * 0.1)
        else:
            step = inputs[k]
        shell.__dict__.update(step)
        shell.do_step(0.1 * (t0 + k), 0.1)
        seen.append(step)
        outs.append(_bits([getattr(shell, n) for n in OUTPUTS]))
    return seen, outs


OUTPUTS = ("cmd", "sp_x", "sp_y", "sp_z", "mission_state", "targets_assigned", "targets_visited", "photo_count",
           "last_photo_target", "current_target", "avoiding", "avoid_count", "last_photo_time", "last_photo_x",
           "last_photo_y")


def test_fmu_state_round_trip_with_the_fast_path(ext):
    """FMI get/set state around steps done by the extension: a restored strategy flies on bit for bit the same."""
    spec = importlib.util.spec_from_file_location("strategy_ext_shell_fast", SRC / "UavStrategy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod._FAST_STEP = ext.step
    shell = _new_shell(mod, [], True, "B")
    _fly(shell, 300, 0)
    state = shell._get_fmu_state()
    ext.reset_stats()
    inputs, first = _fly(shell, 600, 300)
    assert ext.stats()["handled"] > 500 and shell.photo_count > 0
    shell._set_fmu_state(state)
    assert _fly(shell, 600, 300, inputs)[1] == first


def test_outputs_written_are_plain_attributes(shell_module):
    """The extension writes the shell's __dict__: valid only without properties or __setattr__ on the class."""
    cls = shell_module.UavStrategy
    assert cls.__setattr__ is object.__setattr__
    assert not any(hasattr(cls, name) for name in OUTPUTS)


def test_consts_layout_matches_the_params():
    from uavsim.strategy import Strategy
    import array
    s = Strategy(StrategyParams(zones=SQUARES, brake_accel=0.0, home_x=1.5, zone_planning=False))
    c = array.array("d", s._fast_consts).tolist()
    assert c[:10] == [s.p.arrival_radius, s.p.land_threshold, s.p.return_threshold, s.p.lookahead, 1e-6,
                      s.p.cruise_altitude, 1.5, 0.0, 0.0, 2.0]
    assert c[10:15] == [255.0, 255.0, 345.0, 345.0, 4.0] and c[31:36] == [-345.0, -345.0, -255.0, -255.0, 4.0]
    edges = [tuple(c[15 + 4 * i:19 + 4 * i]) for i in range(4)]
    assert sorted(edges) == sorted([(255.0, 255.0, 255.0, 345.0), (255.0, 345.0, 345.0, 345.0),
                                    (345.0, 345.0, 345.0, 255.0), (345.0, 255.0, 255.0, 255.0)])


def _run(ssp: Path, out: Path, pure: bool) -> None:
    env = dict(os.environ)
    env.pop("UAVSIM_PURE_PYTHON", None)
    if pure:
        env["UAVSIM_PURE_PYTHON"] = "1"
    subprocess.run([sys.executable, "-m", "master.cli", "run", str(ssp), "-o", str(out)], check=True, env=env, cwd=ROOT, capture_output=True, text=True)


@pytest.mark.parametrize("ssp", ["paper_zones_1uav_B.ssp"])
def test_whole_run_same_with_and_without_the_extension(tmp_path, ssp):
    """A shipped mission (zone detours included) run with the fast path and with UAVSIM_PURE_PYTHON=1."""
    path = ROOT / "ssp" / ssp
    _run(path, tmp_path / "fast", pure=False)
    _run(path, tmp_path / "pure", pure=True)
    r = subprocess.run([sys.executable, str(ROOT / "bench" / "compare_runs.py"), str(tmp_path / "pure"),
                        str(tmp_path / "fast")], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
