"""The UAV monitor's common step in C (``monitor_step.c``), for small fleets.

A master step of a flying fleet costs the monitor's Python path (``UavMonitor._step_small``) ~10 µs of
interpreter work on a handful of floats, even when every contact and zone check is skipped.  ``ms_step``
does that step in one ctypes call: it gathers the hot values from the master's buffers, and when no phase,
mission state or photo count changed and the skip bounds hold, it adds the step's distances and times and
moves the positions on, exactly as the Python path does (same operations, same order, no FMA).  Otherwise
it changes nothing and the Python path runs on the values it gathered.  The state lives in numpy arrays
shared with C; ``NativeStep.pull``/``push`` copy it to and from the monitor's Python lists around a Python
step.

Like ``master.algorithms.native_loop``, the source is compiled on first use with the system's C compiler
into the per-user cache: as a CPython extension module (``monitor_step_ext.c``) when Python's headers are
installed, else as a plain library called through ctypes (~0.6 us more per call); without a compiler (or
with ``UAVSTUDY_PURE_PYTHON=1``) the monitor runs the Python path, with the same results.
"""
from __future__ import annotations

import ctypes
import functools
import os
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
    _fields_ = [("n", c_int64), ("groups", POINTER(_Group)), ("n_groups", c_int64), ("pos", c_void_p),
                ("p0", c_void_p), ("rm_pos", c_void_p), ("clear", c_void_p), ("F", c_void_p), ("I", c_void_p),
                ("zbox", c_void_p), ("n_zones", c_int64), ("fails", c_int64), ("refresh_every", c_int64),
                ("lo", c_double), ("hi", c_double), ("thr", c_double), ("grow", c_double), ("radius", c_double),
                ("lim", c_double), ("margin", c_double), ("idle", c_int64), ("clear_changed", c_int64),
                ("scratch", c_void_p)]


def disabled() -> bool:
    return os.environ.get("UAVSTUDY_PURE_PYTHON", "") not in ("", "0")


FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared"]
CACHE = "uav-monitor"


def _extension():
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
    module, why_ext = _extension()
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
    """The C state of one monitor (numpy arrays C reads and writes) and ``step(t0, t1)`` -> MS_* code.

    ``F`` holds the float rows dist, dist_xy, ftime, trav, ztrav, zclear, phase and ``I`` the integer rows
    took_off, removed, zfails, idle_fly (a mask) of _step_small's Python lists: one conversion each way."""

    def __init__(self, fn, n: int, hot: list, pos_view: np.ndarray, *, lo: float, hi: float, thr: float,
                 grow: float, radius: float, lim: float, margin: float, refresh_every: int, zone_boxes):
        """``hot``: the monitor's (buffer, index array, out array) per buffer type; ``pos_view`` the (n, 3)
        float64 view of one of the out arrays that holds the positions; the rest as the Python path has
        them (``zone_boxes``: the zones' bounding boxes, ZoneDetector._bounds_list, empty without zones)."""
        self.n = n
        self.p0 = np.zeros((n, 3))
        self.rm_pos = np.zeros((n, 3))
        self.clear = np.full((n, n), -np.inf)
        self.F = np.zeros((7, n))
        self.I = np.zeros((4, n), dtype=np.int64)
        self.zbox = np.array(zone_boxes, dtype=float).reshape(-1, 4)
        self.scratch = np.zeros(5 * n)
        self._keep = []     # everything C points at stays alive with this object
        groups = (_Group * len(hot))()
        for g, (buf, idx, out) in zip(groups, hot):
            idx = np.ascontiguousarray(idx, dtype=np.int64)
            prev = out.copy()       # what the monitor gathered at attach
            self._keep += [buf, idx, out, prev]
            lo_ = hi_ = 0
            if np.shares_memory(out, pos_view):
                lo_ = (pos_view.ctypes.data - out.ctypes.data) // out.itemsize
                hi_ = lo_ + 3 * n
            g.src, g.idx, g.out, g.prev = _addr(buf), _addr(idx), _addr(out), _addr(prev)
            g.count, g.size, g.pos_lo, g.pos_hi = out.size, out.itemsize, lo_, hi_
        self._groups = groups
        s = self.state = _State()
        s.n, s.groups, s.n_groups = n, groups, len(hot)
        s.pos = _addr(pos_view)
        for name in ("p0", "rm_pos", "clear", "F", "I", "zbox", "scratch"):
            setattr(s, name, _addr(getattr(self, name)))
        s.n_zones, s.refresh_every = len(self.zbox), refresh_every
        s.lo, s.hi, s.thr, s.grow, s.radius, s.lim, s.margin = lo, hi, thr, grow, radius, lim, margin
        self._clear_from = None     # the Python matrix self.clear was copied from
        self._n_removed = 0
        self.step = functools.partial(fn, ctypes.addressof(s))

    # -- the Python path's state <-> C -----------------------------------------------------------
    def push(self, m) -> None:
        """C takes over from the monitor ``m``'s Python step (_step_small's lists)."""
        n = self.n
        self.p0[...] = m.p0
        self.F[...] = (m._dist, m._dist_xy, m._ftime, m._trav, m._ztrav, m._zclear, m._ph0l)
        fly = [0] * n
        if m._idle:
            for k in m._idle_fly:
                fly[k] = 1
        self.I[...] = (m._took_off, m._reml, m._zfails, fly)
        if m._rm_idx.size != self._n_removed:
            self.rm_pos[m._rm_idx] = m._rm_pos
            self._n_removed = m._rm_idx.size
        if m._clear is not self._clear_from:
            self.clear[...] = m._clear
            self._clear_from = m._clear
        s = self.state
        s.fails, s.idle, s.clear_changed = m._fails, int(m._idle), 0

    def pull(self, m) -> None:
        """The monitor ``m``'s Python lists take over from C (before a Python step, or at the end)."""
        m.p0 = self.p0.copy()
        m._p0l = m.p0.tolist()
        m._dist, m._dist_xy, m._ftime, m._trav, m._ztrav, m._zclear, _ = self.F.tolist()
        took, _, m._zfails, fly = self.I.tolist()
        m._took_off = [v != 0 for v in took]
        s = self.state
        m._fails = s.fails
        m._idle = s.idle != 0
        m._idle_fly = [k for k, v in enumerate(fly) if v]
        if s.clear_changed:
            m._clear = self._clear_from = self.clear.tolist()
            s.clear_changed = 0


def native_step(n: int, hot, pos_view, **kw) -> NativeStep | None:
    """A NativeStep (keywords: NativeStep's), or None when the Python path must run (disabled, no compiler,
    too many UAVs, positions not float64, a buffer that is not a contiguous numeric array)."""
    if disabled() or n > MAX_UAVS or pos_view.dtype != np.float64:
        return None
    for buf, _idx, out in hot:
        if not (isinstance(buf, np.ndarray) and buf.flags.c_contiguous and buf.dtype.kind in "biuf"
                and buf.dtype == out.dtype):
            return None
    fn, _why = step_function()
    if fn is None:
        return None
    return NativeStep(fn, n, hot, pos_view, **kw)
