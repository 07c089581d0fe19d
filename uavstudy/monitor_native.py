"""The UAV monitor's common step in C (``monitor_step.c``), for few UAVs: an accelerator of the reference step
(``uavstudy.monitor_step``), declared in ``uavstudy.monitor_accel``.

A master step of a flying fleet costs the Python few-UAV step (``monitor_fast.AcceleratedStep``) ~10 us of
interpreter work on a handful of floats, even when every contact and zone check is skipped.  ``ms_step``
does that step in one call: it gathers the hot values from the master's buffers, and when no phase, mission
state or photo count changed and the skip bounds hold, it adds the step's distances and times and moves the
positions on, exactly as the Python step does (same operations, same order, no FMA).  Otherwise it changes
nothing and the Python step runs on the values it gathered.  The C state is an explicit structure
(``_State``, ``MsState`` in C) over numpy arrays; ``NativeStep.push``/``pull`` copy it to and from the
declared fields of ``monitor_fast.FewUavState`` and ``monitor_step.FleetState`` around a Python step.

Built by ``master.native_build`` on first use into the per-user cache: as a CPython extension module
(``monitor_step_ext.c``) when Python's headers are installed, else as a plain library called through ctypes
(~0.6 us more per call); without a compiler, or with ``COSIM_MASTER_PURE_PYTHON=1``, nothing here runs.
"""
from __future__ import annotations

import ctypes
import functools
from ctypes import POINTER, Structure, c_double, c_int64, c_void_p
from pathlib import Path

import numpy as np

from master.native_build import compile_cached, compile_extension

SOURCE = Path(__file__).with_name("monitor_step.c")
EXT_SOURCE = Path(__file__).with_name("monitor_step_ext.c")
MS_DONE, MS_PYTHON, MS_IDLE = 0, 1, 2
MAX_UAVS = 64       # the C step's fixed list of checked UAVs


class _Group(Structure):
    _fields_ = [("src", c_void_p), ("idx", c_void_p), ("out", c_void_p), ("prev", c_void_p),
                ("count", c_int64), ("size", c_int64), ("pos_lo", c_int64), ("pos_hi", c_int64)]


class _State(Structure):
    """``MsState`` of monitor_step.c, field for field."""
    _fields_ = [("n", c_int64), ("groups", POINTER(_Group)), ("n_groups", c_int64),
                ("gathered_position", c_void_p), ("p0", c_void_p), ("removed_position", c_void_p),
                ("pair_clearance", c_void_p), ("floats", c_void_p), ("ints", c_void_p), ("zone_boxes", c_void_p),
                ("n_zones", c_int64), ("pair_misses", c_int64), ("refresh_every", c_int64),
                ("phase_lo", c_double), ("phase_hi", c_double), ("altitude_threshold", c_double),
                ("travel_scale", c_double), ("radius", c_double), ("pair_limit", c_double), ("margin", c_double),
                ("idle_next", c_int64), ("clearance_refreshed", c_int64), ("scratch", c_void_p)]


#: the rows of ``NativeStep.floats`` and ``NativeStep.ints``: FewUavState's per-UAV lists
FLOAT_ROWS = ("distance", "distance_xy", "flight_time", "pair_travel", "zone_travel", "zone_clearance", "phase")
INT_ROWS = ("took_off", "removed", "zone_misses")      # + the idle_flying mask


FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared"]
CACHE = "uav-monitor"


def extension():
    """The extension module (monitor_step_ext.c) for this interpreter, or (None, why not)."""
    return compile_extension(EXT_SOURCE, "_monitor_step_ext", CACHE, FLAGS, depends=SOURCE.read_bytes())


def ctypes_step():
    """``ms_step`` through ctypes (no Python headers needed): (callable, None) or (None, why not)."""
    path, why = compile_cached(SOURCE, "monitor_step", CACHE, FLAGS, what="the monitor step")
    if path is None:
        return None, why
    lib = ctypes.PyDLL(str(path))     # the GIL stays held: a call is far shorter than a release
    lib.ms_step.argtypes = [c_void_p, c_double, c_double]
    lib.ms_step.restype = ctypes.c_int
    return lib.ms_step, None


@functools.cache
def step_function():
    """``ms_step`` as a callable (state address, t0, t1) -> MS_* code: the extension module if Python's
    headers are at hand, else through ctypes; (callable, None), or (None, why neither)."""
    module, why_ext = extension()
    if module is not None:
        return module.step, None
    fn, why = ctypes_step()
    if fn is not None:
        return fn, None
    return None, f"{why_ext}; {why}"


def _addr(a: np.ndarray) -> int:
    assert a.flags.c_contiguous
    return a.ctypes.data


class NativeStep:
    """The C state of one monitor (numpy arrays C reads and writes) and ``step(t0, t1)`` -> MS_* code."""

    def __init__(self, fn, n: int, hot: list, position_view: np.ndarray, *, phase_lo: float, phase_hi: float,
                 altitude_threshold: float, travel_scale: float, radius: float, pair_limit: float, margin: float,
                 refresh_every: int, zone_boxes):
        """``hot``: the monitor's (buffer, index array, out array) per buffer type; ``position_view`` the (n, 3)
        float64 view of one of the out arrays that holds the positions; the rest as the Python step has them
        (``zone_boxes``: the zones' bounding boxes, ``ZoneDetector.bounds``)."""
        self.n = n
        self.p0 = np.zeros((n, 3))
        self.removed_position = np.zeros((n, 3))
        self.pair_clearance = np.full((n, n), -np.inf)
        self.floats = np.zeros((len(FLOAT_ROWS), n))
        self.ints = np.zeros((len(INT_ROWS) + 1, n), dtype=np.int64)
        self.zone_boxes = np.array(zone_boxes, dtype=float).reshape(-1, 4)
        self.scratch = np.zeros(5 * n)
        self._keep = []     # everything C points at stays alive with this object
        groups = (_Group * len(hot))()
        for g, (buf, idx, out) in zip(groups, hot):
            idx = np.ascontiguousarray(idx, dtype=np.int64)
            prev = out.copy()       # what the monitor gathered at attach
            self._keep += [buf, idx, out, prev]
            lo = hi = 0
            if np.shares_memory(out, position_view):
                lo = (position_view.ctypes.data - out.ctypes.data) // out.itemsize
                hi = lo + 3 * n
            g.src, g.idx, g.out, g.prev = _addr(buf), _addr(idx), _addr(out), _addr(prev)
            g.count, g.size, g.pos_lo, g.pos_hi = out.size, out.itemsize, lo, hi
        self._groups = groups
        s = self.state = _State()
        s.n, s.groups, s.n_groups = n, groups, len(hot)
        s.gathered_position = _addr(position_view)
        for name in ("p0", "removed_position", "pair_clearance", "floats", "ints", "zone_boxes", "scratch"):
            setattr(s, name, _addr(getattr(self, name)))
        s.n_zones, s.refresh_every = len(self.zone_boxes), refresh_every
        s.phase_lo, s.phase_hi, s.altitude_threshold = phase_lo, phase_hi, altitude_threshold
        s.travel_scale, s.radius, s.pair_limit, s.margin = travel_scale, radius, pair_limit, margin
        self._clearance_from = None     # the Python matrix self.pair_clearance was copied from
        self._n_removed = 0
        self.step = functools.partial(fn, ctypes.addressof(s))

    @classmethod
    def create(cls, fn, hot, position_view, **kw) -> NativeStep | None:
        """A NativeStep, or None when the Python step must run (too many UAVs, positions not float64, a
        buffer that is not a contiguous numeric array)."""
        n = len(position_view)
        if n > MAX_UAVS or position_view.dtype != np.float64:
            return None
        for buf, _idx, out in hot:
            if not (isinstance(buf, np.ndarray) and buf.flags.c_contiguous and buf.dtype.kind in "biuf"
                    and buf.dtype == out.dtype):
                return None
        return cls(fn, n, hot, position_view, **kw)

    # -- the Python step's state <-> C -----------------------------------------------------------
    def push(self, state, fleet, idle_next: bool, idle_flying) -> None:
        """C takes over from a Python step: ``state`` a ``FewUavState``, ``fleet`` the ``FleetState``, the
        idle flags the ``AcceleratedStep``'s."""
        self.p0[...] = fleet.position
        self.floats[...] = [getattr(state, r) for r in FLOAT_ROWS]
        flying = [0] * self.n
        if idle_next:
            for k in idle_flying:
                flying[k] = 1
        self.ints[...] = [getattr(state, r) for r in INT_ROWS] + [flying]
        n_removed = int(np.count_nonzero(fleet.removed))
        if n_removed != self._n_removed:
            self.removed_position[...] = fleet.removed_position
            self._n_removed = n_removed
        if state.pair_clearance is not self._clearance_from:     # replaced (not modified) when refreshed
            self.pair_clearance[...] = state.pair_clearance
            self._clearance_from = state.pair_clearance
        s = self.state
        s.pair_misses, s.idle_next, s.clearance_refreshed = state.pair_misses, int(idle_next), 0

    def pull(self, state, fleet) -> None:
        """The Python step's ``state`` and ``fleet`` take over from C (before a Python step, or at the end)."""
        fleet.position = self.p0.copy()
        state.position = fleet.position.tolist()
        rows = self.floats.tolist()
        for r, row in zip(FLOAT_ROWS, rows):
            if r != "phase":            # C never changes the phases (a changed phase is Python's step)
                setattr(state, r, row)
        took_off, _removed, state.zone_misses, _flying = self.ints.tolist()
        state.took_off = [v != 0 for v in took_off]
        s = self.state
        state.pair_misses = s.pair_misses
        if s.clearance_refreshed:
            state.pair_clearance = self._clearance_from = self.pair_clearance.tolist()
            s.clearance_refreshed = 0

    def idle(self) -> tuple[bool, list[int]]:
        """(the next step may be idle, the UAVs whose airborne time it extends), as C left them."""
        return self.state.idle_next != 0, [k for k, v in enumerate(self.ints[-1].tolist()) if v]
