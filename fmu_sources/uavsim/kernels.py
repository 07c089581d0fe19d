"""The UAV models' hot loops as plain Python (the reference: what a reader follows and changes) and their
accelerator, kernels.c (the same loops compiled, loaded with ctypes).

A campaign spends most of its time in the dynamics' 0.01 s sub-steps (about 25 per 0.25 s master step
and UAV); the compiled loops do them ~30x faster.  :func:`fly_py` is Dynamics' sub-step written as one loop over a
flat state (the slot layout below), :func:`battery_py` and :func:`battery_step_py` the battery's coulomb counting
and whole step.  kernels.c uses the same layout and only + - * / sqrt, comparisons and copysign, in the same order,
so it gives bit-identical results (declared in uavsim/accelerators.py, checked by the project's harness): whether
the library loads changes the speed, never a result.

The library is compiled by ``fmu_sources/build_fmus.py`` (through master.native_build, uavsim/native.py) into
each FMU's ``resources/uavsim/`` (next to this file).  :func:`load` finds it there, or in a folder the FMU shell
names (its resources folder, for when ``uavsim`` was imported from elsewhere first); without it the Python loops
run.  :func:`build` compiles it outside an FMU.  ``COSIM_MASTER_PURE_PYTHON=1`` forces the Python loops.
"""
from __future__ import annotations

import ctypes
import os
import struct
from math import copysign, sqrt
from pathlib import Path

from . import native

LIBRARY = "_uavsim_kernels.so"
SYMBOLS = ("uav_fly", "uav_battery", "uav_battery_step")

# dynamics state slots (kernels.c: the first enum)
(S_PX, S_PY, S_PZ, S_VX, S_VY, S_VTX, S_VTY, S_VTZ, S_IX, S_IY, S_AX, S_AY, S_HX, S_HY, S_HOLDZ, S_PHASE,
 S_MODE, S_LANDED, S_I, S_N, S_H, S_CMD, S_SPX, S_SPY, S_SPZ, S_WX, S_WY) = range(27)
N_STATE = 27
# dynamics parameter slots
(P_SPEED, P_ACCEL, P_POS_P, P_VEL_P, P_VEL_I, P_ACCEL_Z, P_POS_Z_P, P_SPEED_UP, P_SPEED_DN, P_LAND_SPEED,
 P_LAND_ALT_LOW, P_TAKEOFF_ALT, P_DRAG_K, P_AMAX, P_PUSH) = range(15)
N_PARAM = 15
# battery state slots; battery parameters: cells, resistance, capacity (C), m, m soc values, m ocv values
B_Q, B_E, B_CUR, B_OVER, B_VOLT, B_POW, B_N, B_H, B_DEMAND = range(9)
N_BSTATE = 9
# whole battery step (uav_battery_step): the battery slots, then inputs and published outputs; its parameters are
# the power slots, then the battery parameters above
B_AIR, B_VZ, B_MOTORS, B_CONS, B_SOC, B_DEPL = range(N_BSTATE, N_BSTATE + 6)
N_BSTEP = N_BSTATE + 6
(W_P0, W_TIP2, W_PI, W_V04, W_V02, W_DRAG, W_WEIGHT, W_EFF, W_AVIONICS) = range(9)
N_POWER = 9

TAKEOFF, FLY, LAND = 1, 2, 3
CMD_GOTO, CMD_LAND = 2, 3
MODE_HOLD, MODE_GOTO = 0, 1


def fly_py(s: list, p) -> int:
    """Flying sub-steps s[S_I] .. s[S_N] (or until touch-down) of Dynamics; state in and out in s."""
    speed, accel, pos_p, vel_p, vel_i = p[P_SPEED], p[P_ACCEL], p[P_POS_P], p[P_VEL_P], p[P_VEL_I]
    lin = accel / (pos_p * pos_p)
    accel_z, pos_z_p, speed_up, speed_dn = p[P_ACCEL_Z], p[P_POS_Z_P], p[P_SPEED_UP], p[P_SPEED_DN]
    lin_z = accel_z / (pos_z_p * pos_z_p)
    land_speed, land_alt_low, takeoff_alt = p[P_LAND_SPEED], p[P_LAND_ALT_LOW], p[P_TAKEOFF_ALT]
    k, amax = p[P_DRAG_K], p[P_AMAX]
    push = p[P_PUSH] != 0.0
    n, cmd, h = int(s[S_N]), int(s[S_CMD]), s[S_H]
    goto = cmd == CMD_GOTO
    lim, limz = accel * h, accel_z * h
    wx, wy, spx, spy, spz = s[S_WX], s[S_WY], s[S_SPX], s[S_SPY], s[S_SPZ]
    # drag acts on the velocity relative to the air: the wind's (drag) or the vehicle's own (push)
    dwx, dwy = (0.0, 0.0) if push else (wx, wy)
    px, py, pz, vx, vy = s[S_PX], s[S_PY], s[S_PZ], s[S_VX], s[S_VY]
    vtx, vty, vtz, ix, iy = s[S_VTX], s[S_VTY], s[S_VTZ], s[S_IX], s[S_IY]
    hx, hy, hold_z = s[S_HX], s[S_HY], s[S_HOLDZ]
    phase, mode, i = int(s[S_PHASE]), int(s[S_MODE]), int(s[S_I])
    ax = ay = 0.0
    landed = 0
    while i < n:
        i += 1
        if cmd == CMD_LAND and (phase == TAKEOFF or phase == FLY):
            phase = LAND
            hx, hy = px, py
        if phase == FLY:
            if goto:
                mode = MODE_GOTO
            elif mode == MODE_GOTO:
                mode = MODE_HOLD
                hx, hy = px, py
                hold_z = pz
        if phase == FLY and mode == MODE_GOTO:
            gx, gy, gz = spx, spy, spz
        else:
            gx, gy = hx, hy
            if phase == TAKEOFF:
                gz = takeoff_alt
            elif phase == FLY:
                gz = hold_z
            else:
                gz = pz
        # horizontal controller
        ex, ey = gx - px, gy - py
        d = sqrt(ex * ex + ey * ey)
        if d <= 0.0:
            vmag = 0.0
        elif d <= lin:
            vmag = pos_p * d
        else:
            vmag = sqrt(2.0 * accel * (d - 0.5 * lin))
        vmag = min(speed, vmag)
        if d > 1e-9:
            vdx, vdy = vmag * ex / d, vmag * ey / d
        else:
            vdx = vdy = 0.0
        dvx, dvy = vdx - vtx, vdy - vty
        dvm = sqrt(dvx * dvx + dvy * dvy)
        if dvm > lim:
            dvx, dvy = dvx * lim / dvm, dvy * lim / dvm
        vtx += dvx
        vty += dvy
        sx = sqrt(vx * vx + vy * vy)
        evx, evy = vtx - vx, vty - vy
        ax = dvx / h + vel_p * evx + vel_i * ix + k * sx * vx
        ay = dvy / h + vel_p * evy + vel_i * iy + k * sx * vy
        am = sqrt(ax * ax + ay * ay)
        if am > amax:
            ax, ay = ax * amax / am, ay * amax / am
        else:
            ix += evx * h
            iy += evy * h
        vax, vay = vx - dwx, vy - dwy
        va = sqrt(vax * vax + vay * vay)
        vx += (ax - k * va * vax) * h
        vy += (ay - k * va * vay) * h
        # vertical
        ez = gz - pz
        if phase == LAND:
            vzd = -(land_speed if pz <= land_alt_low else speed_dn)
        else:
            aez = abs(ez)
            if aez <= 0.0:
                vzd = 0.0
            elif aez <= lin_z:
                vzd = pos_z_p * aez
            else:
                vzd = sqrt(2.0 * accel_z * (aez - 0.5 * lin_z))
            vzd = copysign(vzd, ez)
            vzd = max(-speed_dn, min(speed_up, vzd))
        vtz += max(-limz, min(limz, vzd - vtz))
        if push:            # carried by the air mass
            px += (vx + wx) * h
            py += (vy + wy) * h
        else:
            px += vx * h
            py += vy * h
        pz += vtz * h
        # transitions
        if phase == TAKEOFF and pz >= takeoff_alt - 0.2:
            phase = FLY
            mode = MODE_HOLD
            hold_z = takeoff_alt
        if phase == LAND and pz <= 0.0:
            landed = 1
            break
    s[S_PX:S_I + 1] = [px, py, pz, vx, vy, vtx, vty, vtz, ix, iy, ax, ay, hx, hy, hold_z, phase, mode, landed, i]
    return i


def battery_py(s: list, p) -> int:
    """Coulomb counting over s[B_N] sub-steps of s[B_H] at the held demand s[B_DEMAND]; state in s."""
    cells, r, cap, m = p[0], p[1], p[2], int(p[3])
    xs, ys = p[4:4 + m], p[4 + m:4 + 2 * m]
    x0, x1, y0, y1 = xs[0], xs[-1], ys[0], ys[-1]
    n, h, demand = int(s[B_N]), s[B_H], s[B_DEMAND]
    q, e = s[B_Q], s[B_E]
    for i in range(n + 1):
        soc = max(0.0, 1.0 - q / cap)
        if soc <= x0:
            ocv = y0
        elif soc >= x1:
            ocv = y1
        else:
            lo, hi = 0, m                 # bisect_right(xs, soc), written out as kernels.c does it
            while lo < hi:
                mid = (lo + hi) // 2
                if soc < xs[mid]:
                    hi = mid
                else:
                    lo = mid + 1
            j = lo - 1
            ocv = ys[j] + (soc - xs[j]) / (xs[j + 1] - xs[j]) * (ys[j + 1] - ys[j])
        emf = cells * ocv
        if r <= 0.0:
            cur, over = demand / emf, 0
        else:
            disc = emf * emf - 4.0 * r * demand
            if disc < 0.0:
                cur, over = emf / (2.0 * r), 1
            else:
                cur, over = (emf - sqrt(disc)) / (2.0 * r), 0
        volt = emf - cur * r
        pw = volt * cur
        if i < n:
            q += cur * h
            e += pw * h
    s[B_Q:B_POW + 1] = [q, e, cur, over, volt, pw]
    return n


def battery_step_py(s: list, p) -> int:
    """A whole Battery.step: the power demand for the held inputs (battery.power_function, same expression
    order), the coulomb counting of :func:`battery_py` and the outputs the FMU publishes; state in s."""
    if s[B_MOTORS] == 0.0:
        demand = p[W_AVIONICS]
    else:
        airspeed, vz = s[B_AIR], s[B_VZ]
        v2 = airspeed * airspeed
        blade = p[W_P0] * (1.0 + 3.0 * v2 / p[W_TIP2])
        induced = p[W_PI] * sqrt(max(0.0, sqrt(1.0 + v2 * v2 / p[W_V04]) - v2 / p[W_V02]))
        shaft = blade + induced + p[W_DRAG] * v2 * abs(airspeed)
        demand = (shaft + max(0.0, p[W_WEIGHT] * vz)) / p[W_EFF] + p[W_AVIONICS]
    s[B_DEMAND] = demand
    bp = p[N_POWER:]
    battery_py(s, bp)
    cons = s[B_Q] / bp[2]
    s[B_CONS] = cons
    s[B_SOC] = max(0.0, 1.0 - cons)
    s[B_DEPL] = 1.0 if cons >= 1.0 else 0.0
    return int(s[B_N])


class Kernels:
    """The two loops behind one interface.  ``make_fly()`` and ``make_battery()`` return a function
    ``f(state, params)`` for ONE model instance (its own buffers: instances may step in different
    threads) that updates the state list in place; ``compiled`` says which twin runs."""

    def __init__(self, lib=None):
        self.compiled = lib is not None
        self.library = getattr(lib, "_name", None)
        self._lib = lib

    def make_fly(self):
        return fly_py if self._lib is None else _bind(self._lib.uav_fly, N_STATE, S_I)

    def make_battery(self):
        return battery_py if self._lib is None else _bind(self._lib.uav_battery, N_BSTATE, B_N)

    def make_battery_step(self):
        return battery_step_py if self._lib is None else _bind(self._lib.uav_battery_step, N_BSTEP, B_N)


def _bind(c_fn, size: int, result_slot: int):
    buf = (ctypes.c_double * size)()
    # struct moves the values in and out in one C loop each (a ctypes array's slice assignment and iteration go
    # value by value through Python, several times slower); both store the IEEE doubles as they are
    pack_into, unpack_from = struct.Struct(f"{size}d").pack_into, struct.Struct(f"{size}d").unpack_from
    arrays = {}
    last = [None, None]      # the parameters of the previous call (one model instance: every call) and their array

    def run(s, p):
        if p is not last[0]:     # parameters: a tuple fixed per model instance, converted once per value
            a = arrays.get(p)
            if a is None:
                a = arrays[p] = (ctypes.c_double * len(p))(*p)
            last[:] = p, a
        pack_into(buf, 0, *s)
        c_fn(buf, last[1])       # no argtypes: the arrays pass as pointers
        s[:] = unpack_from(buf)
        return int(s[result_slot])
    return run


_loaded: dict = {}       # library path (None: the Python twins) -> Kernels
_found: dict = {}        # folders asked for -> Kernels (every FMU instance asks; the answer is fixed)
_HERE = Path(__file__).resolve().parent


def load(*folders) -> Kernels:
    """The compiled kernels from the first of (this file's folder, *folders) that holds the library,
    else the Python twins.  Cached per library path."""
    if native.disabled():
        return _python()
    key = tuple(str(f) for f in folders)
    k = _found.get(key)
    if k is None:
        k = _found[key] = _search((_HERE, *map(Path, folders)))
    return k


def build() -> tuple[Kernels | None, str | None]:
    """The compiled loops built here (outside an FMU, through master.native_build): (Kernels, None) or (None, why
    not)."""
    if native.disabled():
        return None, f"{native.ENV} is set"
    path, why = native.build(_HERE / "kernels.c", LIBRARY[1:-3], native.FLAGS)
    if path is None:
        return None, why
    k = _search((path.parent,), path.name)
    return (k, None) if k.compiled else (None, f"{path.name} does not load")


def _search(folders, library: str = LIBRARY) -> Kernels:
    for folder in folders:
        path = str(folder / library)
        if path in _loaded:
            return _loaded[path]
        if os.path.isfile(path):
            try:
                lib = ctypes.PyDLL(path)     # keeps the GIL: the loops are short
                for name in SYMBOLS:         # a library built from an older kernels.c lacks the newer kernels
                    getattr(lib, name)
            except (OSError, AttributeError):   # another platform, architecture or version: the Python twins serve
                continue
            _loaded[path] = Kernels(lib)
            return _loaded[path]
    return _python()


def _python() -> Kernels:
    k = _loaded.get(None)
    if k is None:
        k = _loaded[None] = Kernels(None)
    return k
