"""The accelerators of uavsim, each declared with the Python reference it replaces (master/accel.py's Protocol,
satisfied structurally: this module does not import ``master``, it is bundled into the FMUs).

- ``uavsim.kernels-fly``: kernels.c's ``uav_fly``, the dynamics' flying sub-steps (reference: kernels.fly_py);
- ``uavsim.kernels-battery``: kernels.c's ``uav_battery`` and ``uav_battery_step`` (kernels.battery_py,
  kernels.battery_step_py);
- ``uavsim.dynamics-step``, ``uavsim.battery-step``, ``uavsim.wind-step``: the step extensions
  (_dynamics_ext.c, _battery_ext.c, _wind_ext.c), each a shell's whole FMU step (reference: the shell's Python
  step, Dynamics.step, Battery.step_outputs, Wind.mean_over).

Each one's ``cases(rng)`` generates states and inputs from the rng alone: random states of every phase and the
transitions between them (preflight, lift-off, takeoff, goto and hold, landing, touch-down within a step, landed,
re-takeoff), drag and push wind beyond the hold limit, the kernels' shortcut thresholds to the last bit, the
battery's OCV table ends, overload and depletion, wind episodes, ramps, gusts, calm windows, steps on interval
boundaries and before time 0, FMU state saved and restored.  ``reference`` and ``accelerated`` return what the
case observes: every published output after every step and the model's whole final state.

The step extensions are loaded as an FMU loads them: ``load()`` builds them (uavsim/native.py, through
master.native_build when it is importable) into a folder laid out as an FMU's resources (the shell script and
``uavsim/`` with the libraries), from which the shell is imported; the reference shell is the same script run
with ``COSIM_MASTER_PURE_PYTHON=1``.
"""
from __future__ import annotations

import atexit
import importlib.util
import math
import os
import shutil
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

from . import kernels as K
from . import native
from . import params as P

_SHELLS = Path(__file__).resolve().parent.parent      # the shell scripts sit beside the package (an FMU's resources/)
_CODE = ("kernels", "_fly", "_step")                   # the model's bound loops: which twin, not what state


# ------------------------------------------------------------------ helpers

@contextmanager
def _pure():
    """The reference: every accelerator off while a shell is made."""
    old = os.environ.get(native.ENV)
    os.environ[native.ENV] = "1"
    try:
        yield
    finally:
        if old is None:
            del os.environ[native.ENV]
        else:
            os.environ[native.ENV] = old


_classes: dict = {}


def _shell_class(name: str, folder: Path):
    """The shell class ``name`` of the script ``folder/<name>.py`` (imported once per folder)."""
    key = (name, str(folder))
    cls = _classes.get(key)
    if cls is None:
        spec = importlib.util.spec_from_file_location(f"_uavsim_accel_{name}_{len(_classes)}", folder / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        path = list(sys.path)
        try:
            spec.loader.exec_module(mod)
        finally:
            sys.path[:] = path                 # the script puts its folder first: uavsim is imported already
        cls = _classes[key] = getattr(mod, name)
    return cls


def _reference_shell(name: str):
    with _pure():
        cls = _shell_class(name, _SHELLS)
        return cls(instance_name="reference", resources=str(_SHELLS), visible=False)


_staged: dict = {}


def _stage(shell: str, extension: str, with_kernels: bool):
    """(folder laid out as an FMU's resources with the shell and its compiled libraries, None) or (None, why)."""
    if native.disabled():
        return None, f"{native.ENV} is set"
    key = (shell, extension)
    if key in _staged:
        return _staged[key]
    module, why = native.build_extension(extension)
    libs = []
    if module is not None:
        libs.append((Path(module.__file__), extension + native.SUFFIX))
        if with_kernels:
            k, why = K.build()
            if k is None:
                module = None
            else:
                libs.append((Path(k.library), K.LIBRARY))
    if module is None:
        _staged[key] = None, why
        return _staged[key]
    folder = Path(tempfile.mkdtemp(prefix=f"uavsim-accel-{shell}-"))
    atexit.register(shutil.rmtree, folder, True)
    (folder / "uavsim").mkdir()
    shutil.copyfile(_SHELLS / f"{shell}.py", folder / f"{shell}.py")
    for src, target in libs:
        shutil.copyfile(src, folder / "uavsim" / target)
    _staged[key] = folder, None
    return _staged[key]


def _made(cls, folder: Path, params: dict):
    s = cls(instance_name="accelerated", resources=str(folder), visible=False)
    for k, v in params.items():
        setattr(s, k, v)
    return s


def _state(obj, skip=_CODE) -> dict:
    return {k: v for k, v in vars(obj).items() if k not in skip}


def _outcome(fn, *args):
    """What a step returned, or the error it raised (both twins must raise the same)."""
    try:
        return fn(*args)
    except Exception as exc:                      # noqa: BLE001 - the outcome itself is compared
        return f"{type(exc).__name__}: {exc}"


def _doubles(s: list) -> list:
    """A flat state as the doubles both twins mean (the Python loops leave counters and flags as ints)."""
    return [float(x) for x in s]


def _signed_zero(rng):
    return rng.choice([0.0, -0.0])


def _around(rng, x: float, n: int, spread: int = 40) -> list:
    """n values within ``spread`` units in the last place of x, and a few relative steps of 2^-46 away."""
    out = [x]
    for _ in range(n):
        y, u = x, rng.randint(-spread, spread)
        for _ in range(abs(u)):
            y = math.nextafter(y, math.inf if u > 0 else -math.inf)
        out.append(y)
        out.append(x * (1.0 + rng.randint(-400, 400) * 2.0 ** -46))
    return out


class _Declared:
    name = ""
    replaces = ""

    def __repr__(self):
        return f"<accelerator {self.name} of {self.replaces}>"


# ------------------------------------------------------------------ kernels.c

def _fly_params(rng, speed=None, accel=None, pos_p=None, push=None) -> tuple:
    from .dynamics import DynamicsParams
    p = DynamicsParams(wind_push=rng.random() < 0.5 if push is None else push)
    if rng.random() < 0.5:
        p.speed, p.accel, p.pos_p = rng.uniform(2.0, 15.0), rng.uniform(0.8, 4.0), rng.uniform(0.4, 2.0)
        p.vel_p, p.vel_i, p.mass = rng.uniform(0.5, 3.0), rng.uniform(0.0, 2.0), rng.uniform(0.8, 3.0)
    for field, v in (("speed", speed), ("accel", accel), ("pos_p", pos_p)):
        if v is not None:
            setattr(p, field, v)
    return (p.speed, p.accel, p.pos_p, p.vel_p, p.vel_i, p.accel_z, p.pos_z_p, p.speed_up, p.speed_dn,
            p.land_speed, p.land_alt_low, p.takeoff_altitude, p.drag_k, p.max_horizontal_accel,
            1.0 if p.wind_push else 0.0)


def _fly_state(rng, takeoff_alt: float = 20.0) -> list:
    s = [0.0] * K.N_STATE
    phase = rng.choice([K.TAKEOFF, K.FLY, K.FLY, K.LAND])
    z = {K.TAKEOFF: rng.choice([rng.uniform(0.0, takeoff_alt), takeoff_alt - 0.2 - rng.uniform(0.0, 0.05)]),
         K.FLY: rng.uniform(0.0, 60.0), K.LAND: rng.choice([rng.uniform(0.0, 0.06), rng.uniform(0.0, 30.0)])}[phase]
    still = rng.random() < 0.15

    def u(lo, hi):              # zeros of both signs: still air and no thrust take shortcuts that must not show
        return _signed_zero(rng) if still else rng.uniform(lo, hi)
    s[K.S_PX], s[K.S_PY], s[K.S_PZ] = rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0), z
    s[K.S_VX], s[K.S_VY], s[K.S_VTX], s[K.S_VTY], s[K.S_VTZ] = (u(-12, 12), u(-12, 12), u(-12, 12), u(-12, 12),
                                                                 u(-2.5, 2.5))
    s[K.S_IX], s[K.S_IY] = u(-5.0, 5.0), u(-5.0, 5.0)
    if rng.random() < 0.2:
        s[K.S_HX], s[K.S_HY] = s[K.S_PX], s[K.S_PY]
    else:
        s[K.S_HX], s[K.S_HY] = rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0)
    s[K.S_HOLDZ], s[K.S_PHASE], s[K.S_MODE] = rng.uniform(0.0, 50.0), phase, rng.choice([0, 1])
    n = rng.choice([1, 10, 25, 100])
    s[K.S_I], s[K.S_N] = rng.randrange(n), n
    s[K.S_H], s[K.S_CMD] = rng.choice([0.01, 0.01, 0.0125, 0.05, 1.0 / 3.0]), rng.choice([0, 1, 2, 2, 3])
    s[K.S_SPX], s[K.S_SPY], s[K.S_SPZ] = rng.uniform(-400, 400), rng.uniform(-400, 400), rng.uniform(0, 60)
    if rng.random() < 0.6:
        s[K.S_WX], s[K.S_WY] = rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)
    else:
        s[K.S_WX], s[K.S_WY] = _signed_zero(rng), _signed_zero(rng)
    return s


def _one_goto(goal, vt=(0.0, 0.0), vel=(0.0, 0.0), h=0.01) -> list:
    """One goto sub-step from (0, 0, 20) towards (goal, 20)."""
    s = [0.0] * K.N_STATE
    s[K.S_PZ], s[K.S_HOLDZ], s[K.S_PHASE], s[K.S_MODE] = 20.0, 20.0, K.FLY, 1
    s[K.S_VX], s[K.S_VY] = vel
    s[K.S_VTX], s[K.S_VTY] = vt
    s[K.S_N], s[K.S_H], s[K.S_CMD] = 1, h, K.CMD_GOTO
    s[K.S_SPX], s[K.S_SPY], s[K.S_SPZ] = goal[0], goal[1], 20.0
    return s


class KernelsFly(_Declared):
    """kernels.c's flying sub-steps.  Besides random states: states at the two thresholds where the C code skips a
    square root (the speed limit far from the goal, the unlimited change of the reference velocity), to the last
    bit, and odd parameters (zero, negative or infinite speed and acceleration limits)."""
    name = "uavsim.kernels-fly"
    replaces = "uavsim.kernels:fly_py"

    def load(self):
        k, why = K.build()
        return (None, why) if k is None else (k, None)

    def cases(self, rng):
        for _ in range(1500):
            yield _fly_state(rng), _fly_params(rng)
        for _ in range(4):                         # the speed limit's shortcut
            speed, accel, pos_p = rng.choice([(10.0, 2.5, 1.0), (7.3, 1.9, 0.8), (12.5, 3.3, 1.7), (0.1, 2.5, 1.0)])
            p = _fly_params(rng, speed, accel, pos_p, push=False)
            lin = accel / (pos_p * pos_p)
            for d in _around(rng, speed * speed / (2.0 * accel) + 0.5 * lin, 12):
                a = rng.uniform(0.0, 2.0 * math.pi)
                for goal in ((d, 0.0), (0.0, -d), (d * math.cos(a), d * math.sin(a))):
                    yield _one_goto(goal), p
        for _ in range(4):                         # the unlimited change's shortcut, at the goal
            h = rng.choice([0.01, 0.0125, 0.05, 1.0 / 3.0])
            p = _fly_params(rng, 10.0, 2.5, 1.0, push=False)
            for r in _around(rng, 2.5 * h, 12):
                a = rng.uniform(0.0, 2.0 * math.pi)
                for vt in ((r, 0.0), (0.0, -r), (r * math.cos(a), r * math.sin(a))):
                    yield _one_goto((0.0, 0.0), vt=vt, h=h), p
        for speed, accel in ((0.0, 2.5), (-0.0, 2.5), (-3.0, 2.5), (math.inf, 2.5), (10.0, 0.0), (10.0, math.inf)):
            p = _fly_params(rng, speed, accel, 1.0, push=False)
            for _ in range(10):
                goal = (rng.uniform(-500.0, 500.0), rng.choice([0.0, rng.uniform(-500.0, 500.0)]))
                vt = (rng.uniform(-12.0, 12.0), rng.choice([0.0, -0.0, rng.uniform(-0.05, 0.05)]))
                yield _one_goto(goal, vt=vt, vel=vt), p
        p = _fly_params(rng, 10.0, -2.5, 1.0, push=False)     # negative: always limited (only at the goal: the
        for _ in range(10):                                   # reference's square root elsewhere raises)
            vt = (rng.uniform(-12.0, 12.0), rng.choice([0.0, -0.0, rng.uniform(-0.05, 0.05)]))
            yield _one_goto((0.0, 0.0), vt=vt, vel=vt), p

    def reference(self, case):
        s, p = list(case[0]), case[1]
        return K.fly_py(s, p), _doubles(s)

    def accelerated(self, impl, case):
        s, p = list(case[0]), case[1]
        return impl.make_fly()(s, p), _doubles(s)


def _battery_params(rng) -> tuple:
    from .battery import BatteryParams, PowerParams, _power_slots
    pp = PowerParams()
    if rng.random() < 0.5:
        pp = PowerParams(mass=rng.uniform(0.5, 5), rho=rng.uniform(0.9, 1.3), efficiency=rng.uniform(0.4, 0.9),
                         avionics_power=rng.uniform(0, 20))
    bp = BatteryParams(cells=rng.choice([3, 3, 2, 4, 6]), capacity_ah=rng.choice([5.1, rng.uniform(0.01, 10.0)]),
                       cell_resistance=rng.choice([0.012, 0.0, rng.uniform(0.0, 0.5)]))
    return (*_power_slots(pp), float(bp.cells), bp.resistance, bp.capacity_c, float(len(bp.ocv_soc)),
            *map(float, bp.ocv_soc), *map(float, bp.ocv_cell))


class KernelsBattery(_Declared):
    """kernels.c's battery loops: the coulomb counting alone and the whole step (power demand, counting, outputs);
    charge from full to beyond empty (the OCV table's ends, depletion), powers the pack cannot give (overload)."""
    name = "uavsim.kernels-battery"
    replaces = "uavsim.kernels:battery_step_py"

    def load(self):
        k, why = K.build()
        return (None, why) if k is None else (k, None)

    def cases(self, rng):
        for _ in range(1500):
            whole = rng.random() < 0.7
            pw = _battery_params(rng)
            p = pw if whole else pw[K.N_POWER:]
            cap = p[K.N_POWER + 2] if whole else p[2]
            s = [0.0] * (K.N_BSTEP if whole else K.N_BSTATE)
            s[K.B_Q] = rng.choice([rng.uniform(0.0, cap), rng.uniform(0.9 * cap, 1.2 * cap), 0.0,
                                   rng.uniform(-0.1, 0.0) * cap])
            s[K.B_E] = rng.uniform(0.0, 5e5)
            s[K.B_N], s[K.B_H] = rng.choice([0, 1, 2, 5, 20]), rng.choice([0.05, 0.02, 0.25 / 3])
            if whole:
                s[K.B_AIR] = rng.choice([rng.uniform(0.0, 25.0), rng.uniform(0.0, 400.0), 0.0, -0.0, math.nan])
                s[K.B_VZ] = rng.choice([rng.uniform(-5.0, 5.0), 0.0])
                s[K.B_MOTORS] = rng.choice([0.0, 1.0])
            else:
                s[K.B_DEMAND] = rng.choice([rng.uniform(0.0, 400.0), rng.uniform(0.0, 50000.0), 0.0])
            yield whole, s, p

    def reference(self, case):
        whole, s, p = case[0], list(case[1]), case[2]
        return (K.battery_step_py if whole else K.battery_py)(s, p), _doubles(s)

    def accelerated(self, impl, case):
        whole, s, p = case[0], list(case[1]), case[2]
        return (impl.make_battery_step() if whole else impl.make_battery())(s, p), _doubles(s)


# ------------------------------------------------------------------ the step extensions

DYN_OUT = ("x", "y", "z", "vx", "vy", "vz", "airspeed", "groundspeed", "tilt", "phase", "ready", "lat", "lon", "alt")
BAT_OUT = ("soc", "consumed", "voltage", "current", "power", "energy_used", "depleted")
WIND_OUT = ("wind_x", "wind_y", "wind_z", "wind_speed", "wind_level")


class _ShellStep(_Declared):
    """A shell's whole FMU step: ``shell`` made with ``params``, its model's public state set to ``state``, then
    ``steps`` (inputs, current time, step size), with the FMU state saved at ``save`` and restored at ``restore``
    (the steps after it replayed), and finally lat/lon/alt style ``probes`` (outputs set, computed outputs read)."""
    shell = extension = ""
    outputs: tuple = ()
    with_kernels = True

    def load(self):
        folder, why = _stage(self.shell, self.extension, self.with_kernels)
        if folder is None:
            return None, why
        cls = _shell_class(self.shell, folder)
        probe = _made(cls, folder, {})
        probe.exit_initialization_mode()
        if getattr(probe, "_ext", None) is None:
            return None, f"{self.shell} made from {folder} did not load {self.extension}"
        return (cls, folder), None

    def reference(self, case):
        return self._run(_reference_shell(self.shell), case, pure=True)

    def accelerated(self, impl, case):
        cls, folder = impl
        return self._run(_made(cls, folder, {}), case, pure=False)

    def _run(self, s, case, pure):
        for k, v in case["params"].items():
            setattr(s, k, v)
        if pure:
            with _pure():
                s.setup_experiment(0.0, None, None)
                s.exit_initialization_mode()
        else:
            s.setup_experiment(0.0, None, None)
            s.exit_initialization_mode()
        for k, v in case.get("state", {}).items():
            setattr(s.model, k, list(v) if type(v) is list else v)
        seen, saved = [], None
        steps = case["steps"]
        i = 0
        restored = False
        while i < len(steps):
            if i == case.get("save"):
                saved = s._get_fmu_state()
            if i == case.get("restore") and not restored:
                s._set_fmu_state(saved)
                i, restored = case["save"], True
            inputs, t, h = steps[i]
            for k, v in inputs.items():
                setattr(s, k, v)
            seen.append((_outcome(s.do_step, t, h), [getattr(s, n) for n in self.outputs]))
            i += 1
        for probe in case.get("probes", ()):
            for k, v in probe.items():
                setattr(s, k, v)
            seen.append([getattr(s, n) for n in self.outputs])
        return seen, [(n, getattr(s, n)) for n in self.outputs], _state(s.model)


def _dynamics_state(rng, takeoff_alt: float) -> dict:
    phase = rng.choice([0, 1, 2, 2, 2, 3, 3, 4])
    z = {0: 0.0, 4: 0.0, 1: rng.choice([rng.uniform(0.0, takeoff_alt), takeoff_alt - 0.2 - rng.uniform(0.0, 0.05)]),
         2: rng.uniform(0.0, 60.0), 3: rng.choice([rng.uniform(0.0, 0.06), rng.uniform(0.0, 30.0)])}[phase]
    pos = [rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0), z]
    hold = [pos[0], pos[1]] if rng.random() < 0.2 else [rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0)]
    still = rng.random() < 0.15 or phase in (0, 4)

    def u(lo, hi):
        return _signed_zero(rng) if still else rng.uniform(lo, hi)
    elapsed = rng.uniform(0.0, 6.0)
    return dict(pos=pos, vel=[u(-12.0, 12.0), u(-12.0, 12.0), u(-3.0, 3.0)], vt=[u(-12.0, 12.0), u(-12.0, 12.0)],
                vtz=u(-2.5, 2.5), integ=[u(-5.0, 5.0), u(-5.0, 5.0)], hold=hold, hold_z=rng.uniform(0.0, 50.0),
                a_cmd=[u(-6.0, 6.0), u(-6.0, 6.0)], phase=phase, mode=rng.choice(["goto", "hold"]),
                preflight_elapsed=elapsed, ready=elapsed >= 5.0 if rng.random() < 0.8 else rng.random() < 0.5,
                time=rng.uniform(0.0, 1000.0), wind=(rng.uniform(-9, 9), rng.uniform(-9, 9), 0.0))


def _dynamics_inputs(rng) -> dict:
    wind = [rng.uniform(-20.0, 20.0) if rng.random() < 0.6 else _signed_zero(rng) for _ in range(3)]
    return dict(cmd=rng.choice([0, 1, 2, 2, 3, 3, 2.0, 5, -1]), sp_x=rng.uniform(-400.0, 400.0),
                sp_y=rng.uniform(-400.0, 400.0), sp_z=rng.uniform(0.0, 60.0), wind_x=wind[0], wind_y=wind[1],
                wind_z=wind[2])


def _position_probes(rng, n: int) -> list:
    return [dict(zip("xyz", [rng.choice([0.0, -0.0, rng.uniform(-5e4, 5e4), rng.uniform(-50.0, 50.0)])
                             for _ in range(3)])) for _ in range(n)]


class DynamicsStep(_ShellStep):
    """UavDynamics' step in C (_dynamics_ext.c, with kernels.c's sub-steps) and its lat/lon/alt getters."""
    name = "uavsim.dynamics-step"
    replaces = "uavsim.dynamics:Dynamics.step"
    shell, extension, outputs = "UavDynamics", "_dynamics_ext", DYN_OUT

    def cases(self, rng):
        for _ in range(300):                       # random states of every phase, a few steps from each
            params = dict(wind_push=rng.random() < 0.5)
            if rng.random() < 0.3:                 # origins all over the globe for the geodetic outputs
                params.update(origin_lat=rng.uniform(-89.0, 89.0), origin_lon=rng.uniform(-180.0, 180.0),
                              origin_alt=rng.uniform(-400.0, 4000.0))
            steps = [(_dynamics_inputs(rng), j * 0.1,
                      rng.choice([0.1, 0.1, 0.25, 0.01, 0.05, 1.0, 0.37, 0.0, -0.1, math.nan])) for j in range(6)]
            yield dict(params=params, state=_dynamics_state(rng, P.TAKEOFF_ALTITUDE), steps=steps,
                       probes=_position_probes(rng, 3))
        for _ in range(2):                         # whole flights through every phase twice, FMU state restored
            yield self._flight(rng)
        yield dict(params={}, steps=[(dict(wind_x="gust"), 0.0, 0.1), (dict(wind_x=0.0), 0.0, 0.1)])

    @staticmethod
    def _flight(rng):
        push = rng.random() < 0.5
        t0, t1, t2, t3 = rng.uniform(0, 6), rng.uniform(10, 25), rng.uniform(60, 120), rng.uniform(150, 200)
        h = rng.choice([0.1, 0.25])
        steps, t = [], 0.0
        while t < t3 + 40.0:
            cmd = 0 if t < t0 else 1 if t < t1 else (2 if (t // 7) % 3 else 0) if t < t2 else 3 if t < t3 else 1
            sp = ((t // 15) * 37.0 - 60.0, 80.0 - (t // 11) * 29.0, 20.0 + (t // 20) * 3)
            steps.append((dict(cmd=cmd, sp_x=sp[0], sp_y=sp[1], sp_z=sp[2], wind_x=rng.uniform(-11, 3),
                               wind_y=rng.uniform(-4, 4), wind_z=rng.uniform(-1, 1)), t, h))
            t += h
        save = rng.randrange(len(steps) // 3, len(steps) // 2)
        return dict(params=dict(wind_push=push), steps=steps, save=save, restore=save + rng.randrange(10, 200),
                    probes=_position_probes(rng, 2))


class BatteryStep(_ShellStep):
    """UavBattery's step in C (_battery_ext.c, with kernels.c's whole battery step)."""
    name = "uavsim.battery-step"
    replaces = "uavsim.battery:Battery.step_outputs"
    shell, extension, outputs = "UavBattery", "_battery_ext", BAT_OUT

    def cases(self, rng):
        for _ in range(300):
            params = {}
            if rng.random() < 0.3:
                params = dict(capacity_ah=rng.uniform(0.5, 8.0), cell_resistance=rng.choice([0.0, rng.uniform(0, 0.3)]),
                              initial_soc=rng.uniform(0.0, 1.0))
            cap = params.get("capacity_ah", 5.1) * 3600.0
            steps = []
            for j in range(8):
                steps.append((dict(airspeed=rng.choice([rng.uniform(0.0, 25.0), rng.uniform(0.0, 400.0), 0.0]),
                                   vz=rng.choice([rng.uniform(-5.0, 5.0), 0.0]),
                                   phase=rng.choice([0, 1, 2, 3, 4, 5, -1, 2.0])),
                              j * 0.1, rng.choice([0.1, 0.1, 0.25, 0.01, 1.0, 0.37, 0.0, -0.5, math.nan])))
            state = dict(charge_used=rng.choice([rng.uniform(0.0, cap), rng.uniform(0.9 * cap, 1.2 * cap), 0.0]),
                         energy_used=rng.uniform(0.0, 5e5))
            yield dict(params=params, state=state, steps=steps)
        steps = [(dict(phase=2, airspeed=rng.uniform(0, 15), vz=rng.uniform(-2, 2)), 0.25 * j, 0.25) for j in range(400)]
        yield dict(params={}, steps=steps, save=100, restore=300)
        yield dict(params={}, steps=[(dict(phase="takeoff"), 0.0, 0.1), (dict(phase=1), 0.0, 0.1)])


def _wind_params(rng) -> dict:
    di = rng.choice([10.0, 10.0, 2.5, 0.7, 1.0, rng.uniform(0.3, 12.0)])
    return dict(
        probability=rng.choice([0.0, 1.0, 0.15, 0.5, 0.025, rng.random(), -0.0, 1e-300]),
        seed=rng.randrange(1 << 31), stream=rng.choice([-1, 0, 3]), decision_interval=di,
        duration=rng.choice([di, di, 0.5 * di, 2.0 * di, rng.uniform(0.1, di)]),
        ramp=rng.choice([min(1.0, 0.25 * di), 0.0, rng.uniform(0.0, di), 2.0 * di]),
        speed_weak=rng.choice([4.0, 0.0, rng.uniform(0.1, 20.0)]),
        speed_moderate=rng.choice([7.0, rng.uniform(0.1, 20.0)]),
        speed_strong=rng.choice([11.0, rng.uniform(0.1, 20.0)]),
        direction_deg=rng.choice([90.0, 0.0, 45.0, rng.uniform(-360.0, 360.0)]),
        gusts=rng.random() < 0.4, gust_length=rng.choice([2.0, 0.0, di, 3.0 * di, rng.uniform(0.0, di)]),
        gust_amplitude=rng.choice([0.3, rng.uniform(0.0, 2.0)]), turbulence=rng.random() < 0.1,
        step_mean=rng.random() < 0.95)


def _wind_steps(rng, di: float, n: int) -> list:
    """Fixed steps on and off episode boundaries, steps whose first sample falls on a boundary (within the rounding
    of t / T), long and tiny steps, jumps back to intervals drawn already and a few before time 0."""
    h = rng.choice([0.25, 0.25, 0.1, 0.5, 1.0, rng.uniform(0.01, 3.0), 0.05, 0.049999999, 12.0, 1e-7])
    t = rng.choice([0.0, -h, -2.5 * h, rng.uniform(0.0, 50.0)])
    out = []
    for _ in range(n):
        r = rng.random()
        if r < 0.08:
            t = rng.randrange(0, 12) * di - h + rng.choice([0.0, 1e-12, -1e-12, 1e-9, -1e-9, 0.5 * h])
        elif r < 0.13:
            m = min(200, max(1, math.ceil(h / 0.05 - 1e-9)))       # mean_over's sample count
            t = rng.randrange(1, 12) * di - h - 0.5 * h / m + rng.choice([0.0, 0.0, 1e-15, -1e-15, 4e-15])
        elif r < 0.18:
            t = rng.uniform(-2.0 * h, 30.0 * di)
        elif r < 0.21:
            h = rng.choice([0.25, rng.uniform(1e-6, 25.0), 0.05, 9.9999, 60.0, 0.0, -0.25])
        out.append(({}, t, h))
        t += h
    return out


class WindStep(_ShellStep):
    """UavWind's step in C (_wind_ext.c): the wind's mean over the coming step, calm and windy, with gusts; it
    leaves random draws and turbulence to the Python step."""
    name = "uavsim.wind-step"
    replaces = "uavsim.wind:Wind.mean_over"
    shell, extension, outputs, with_kernels = "UavWind", "_wind_ext", WIND_OUT, False

    def cases(self, rng):
        for _ in range(200):
            params = _wind_params(rng)
            yield dict(params=params, steps=_wind_steps(rng, params["decision_interval"], 40))
        for i in range(4):                         # the paper campaign's wind: 10 s episodes, 1 s ramps, 0.25 s steps
            params = dict(probability=rng.choice([0.025, 0.075, 0.15, 1.0]), seed=rng.randrange(1 << 31),
                          stream=rng.choice([-1, 0, 1, 2, 3]), decision_interval=10.0, duration=10.0, ramp=1.0,
                          gusts=rng.random() < 0.3)
            steps = [({}, n * 0.25, 0.25) for n in range(600)]
            yield dict(params=params, steps=steps, save=200, restore=rng.randrange(250, 400))


KERNELS_FLY = KernelsFly()
KERNELS_BATTERY = KernelsBattery()
DYNAMICS_STEP = DynamicsStep()
BATTERY_STEP = BatteryStep()
WIND_STEP = WindStep()


# ------------------------------------------------------------------ the channel's step

def _channel_zone(rng) -> list:
    """A zone of the paper area (oblique quadrilaterals), an axis-aligned square, or a random polygon (concave
    about half the time)."""
    from .strategy_accel import PAPER_ZONES, SQUARES
    r = rng.random()
    if r < 0.3:
        return rng.choice(PAPER_ZONES)
    if r < 0.45:
        return rng.choice(SQUARES)
    cx, cy, s = rng.uniform(-250, 250), rng.uniform(-250, 250), rng.uniform(10, 80)
    corners = ((-1, -1), (1, -1), (1.2, 0.5), (0, 1), (-1, 0.7)) if rng.random() < 0.5 else \
        ((-1, -1), (1, -1), (1, 1), (0.1, 0.1), (-1, 1))
    return [(cx + s * dx, cy + s * dy) for dx, dy in corners]


def _channel_params(rng, n: int) -> dict:
    mode = rng.choice(["radio"] * 6 + ["perfect", "none"])
    zones = [_channel_zone(rng) for _ in range(rng.choice([0, 1, 2, 3, 3]))]
    return dict(mode=mode, range=rng.choice([300.0, 120.0, 50.0, 0.0, math.inf, rng.uniform(5.0, 400.0)]),
                period=rng.choice([0.5, 1.0, 0.25, 0.3, rng.uniform(0.05, 2.0)]),
                latency=rng.choice([0.0, 0.2, 0.35, 1.3, rng.uniform(0.0, 3.0)]),
                loss=rng.choice([0.0, 0.1, 0.5, 0.9, 1.0, rng.random()]), k=rng.randint(1, 4),
                seed=rng.choice([0, 1, 7, rng.randrange(1 << 40), -rng.randrange(1 << 20)]),
                line_of_sight=bool(zones) and rng.random() < 0.8, zones=zones, n_uavs=n,
                near_miss=rng.choice([10.0, 30.0, rng.uniform(0.0, 60.0)]))


def _grazing(rng, zones, a):
    """A point such that the line from ``a`` passes a zone's corner within a few mm, or about an edge's middle
    (the line of sight undecided by the compiled test, left to ZoneMap.blocked), or crosses the zone."""
    z = rng.choice(zones)
    c = list(rng.choice(z)) if rng.random() < 0.6 else \
        [0.5 * (p + q) for p, q in zip(*rng.sample(z, 2))]
    off = rng.choice([0.0, 1e-4, -1e-4, 2e-3, -2e-3, 1e-7, rng.uniform(-1.0, 1.0)])
    dx, dy = c[0] - a[0], c[1] - a[1]
    L = math.hypot(dx, dy) or 1.0
    f = rng.uniform(1.2, 3.0)
    return a[0] + f * dx - off * dy / L, a[1] + f * dy - off * dx / L


class ChannelStep(_Declared):
    """UavChannel's step in C (_channel_ext.c): Channel.advance, run on fleets flying random walks over many steps
    with every parameter varied (range, period, latency, loss, k, seed, mode, near-miss distance) and zones that
    block the line of sight; UAVs that fall silent (their clock stops) and come back, pairs at exactly the range,
    lines of sight grazing a zone's corner or edge, several sending instants in one step and several arriving in
    one step, and now and then a position the compiled step leaves to Python (an int, a NaN)."""
    name = "uavsim.channel-step"
    replaces = "uavsim.channel:Channel.advance"

    def load(self):
        if native.disabled():
            return None, f"{native.ENV} is set"
        ext = native.load_extension("_channel_ext")
        return (ext, None) if ext is not None else native.build_extension("_channel_ext")

    def cases(self, rng):
        for _ in range(60):
            yield self._flight(rng, rng.choice([1, 2, 3, 4, 4, 4, 6, 8]), rng.randint(20, 120))
        yield self._flight(rng, 64, 30)

    @staticmethod
    def _flight(rng, n: int, steps: int) -> dict:
        from .channel import BROADCAST_INT
        params = _channel_params(rng, n)
        h = rng.choice([0.1, 0.1, 0.25, 0.05, 0.3, 1.0, rng.uniform(0.01, 1.5)])
        spread = rng.choice([30.0, 150.0, 400.0])
        pos = [[rng.uniform(-spread, spread), rng.uniform(-spread, spread), rng.choice([0.0, rng.uniform(0, 40)])]
               for _ in range(n)]
        vel = [[rng.uniform(-12, 12), rng.uniform(-12, 12), rng.uniform(-1, 1)] for _ in range(n)]
        clocks = [0.0] * n
        silent = {rng.randrange(n): (rng.randrange(steps), rng.randrange(steps)) for _ in range(rng.randint(0, 2))}
        t = rng.choice([0.0, 0.0, rng.uniform(0.0, 100.0), -h])
        out = []
        for s in range(steps):
            if params["zones"] and n > 1 and rng.random() < 0.2:       # a line of sight along a zone's corner
                i, j = rng.sample(range(n), 2)
                pos[j][:2] = _grazing(rng, params["zones"], pos[i])
            if n > 1 and rng.random() < 0.05 and math.isfinite(params["range"]):     # exactly at the range
                i, j = rng.sample(range(n), 2)
                pos[j] = [pos[i][0] + params["range"], pos[i][1], pos[i][2]]
            uavs = []
            for i in range(n):
                lo, hi = silent.get(i, (steps, steps))
                if not min(lo, hi) <= s < max(lo, hi):
                    clocks[i] = t + h
                for a in range(3):
                    pos[i][a] += h * vel[i][a]
                    if rng.random() < 0.02:
                        vel[i][a] = -vel[i][a]
                b = dict(zip(("x", "y", "z"), pos[i]), vx=vel[i][0], vy=vel[i][1], wx=rng.uniform(-300, 300),
                         wy=rng.uniform(-300, 300), clock=clocks[i])
                b.update({name: rng.randrange(-(1 << 31), 1 << 31) if name[-1].isdigit() else rng.randrange(-1, 12)
                          for name in BROADCAST_INT})
                if rng.random() < 0.003:          # values the compiled step leaves to Python
                    b[rng.choice(["x", "y", "z", "clock"])] = rng.choice([3, math.nan, math.inf])
                uavs.append(b)
            out.append((t, h if rng.random() < 0.9 else rng.choice([0.5 * h, 3.0 * h]), uavs))
            t += out[-1][1]
        return dict(params=params, steps=out)

    @staticmethod
    def _channel(case):
        from .channel import Channel, ChannelParams
        return Channel(ChannelParams(**case["params"]))

    @staticmethod
    def _observed(ch, seen) -> tuple:
        state = {k: v for k, v in vars(ch).items() if k not in ("p", "zones")}
        return seen, state

    def reference(self, case):
        ch = self._channel(case)
        seen = []
        for t, h, uavs in case["steps"]:
            seen.append(_outcome(ch.advance, t, h, [(b["x"], b["y"], b["z"]) for b in uavs],
                                 [b["clock"] for b in uavs], uavs.__getitem__))
        return self._observed(ch, seen)

    def accelerated(self, impl, case):
        from .channel import BROADCAST_INT, BROADCAST_REAL
        ch = self._channel(case)
        fields = BROADCAST_REAL + BROADCAST_INT
        names = [tuple(f"uav{i + 1}_{f}" for f in fields) for i in range(ch.n)]
        seen = []
        for t, h, uavs in case["steps"]:
            variables = {f"uav{i + 1}_{f}": b[f] for i, b in enumerate(uavs) for f in fields}
            got = _outcome(impl.advance, ch, t, h, variables, names)
            if got is NotImplemented:             # as the shell does: the Python step
                got = _outcome(ch.advance, t, h, [(b["x"], b["y"], b["z"]) for b in uavs],
                               [b["clock"] for b in uavs], uavs.__getitem__)
            seen.append(got)
        return self._observed(ch, seen)


CHANNEL_STEP = ChannelStep()
