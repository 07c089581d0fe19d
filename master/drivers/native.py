"""The step driver in C for systems of native FMI 2.0 and 3.0 co-simulation FMUs (a ``base.StepDriver``).

From Python, each FMI call costs ~0.4 µs of ctypes overhead, three calls per FMU step, several times what a
cheap FMU itself costs. Here the compiled step (compiled.py) is described once as a list of operations on
the master's own buffers (transfers with their factor/offset, setters, doStep, getters, staging of
components on a step multiple) and ``native_loop.c`` runs many master steps of it per call, recording the
samples into the recording's block itself (after the steps ``Recording.samples_after`` names). It returns to
Python at every point where Python must look (a status above Warning, an FMI 3.0 doStep that returned early or asks
to terminate, a full block, a non-finite output, the end of the chunk), and Python then does exactly what the
reference loop (``Execution._steps``) does there, so results, errors and rows kept are the same, bit for bit.

It applies only when nothing else needs Python between steps: a fixed-step algorithm whose step is the
compiled one (jacobi, gauss-seidel; no extrapolation, no rollback), no monitors, observers or manipulators
besides the recording (a supervised child's recording lets the loop keep its shared progress header: time,
rows, and the component whose FMI call is in progress, see ``PROGRESS_SLOTS``), every active component a
native FMI 2.0 co-simulation FMU with Real/Integer/Boolean ports or an FMI 3.0 one with Float64 ports and
neither event mode nor early return (pythonfmu FMUs in process, model exchange and FMI 1.0 keep the Python
path), no value maps on inputs, and numeric recorded values. Otherwise the Python path runs, unchanged;
run.json's ``native_loop`` says which ran and why.

The C source is compiled on first use by ``master.native_build`` (the system's C compiler, ``$CC`` or ``cc``)
into the per-user cache and loaded with ctypes: no build step at install, no new dependency (cffi or numba would
be one, and numba a heavy one), and without a compiler everything still runs, on the Python path.
"""
from __future__ import annotations

import ctypes
import functools
import time
from ctypes import POINTER, Structure, c_double, c_longlong, c_void_p
from pathlib import Path

import numpy as np

from .. import interrupts
from ..algorithms.gauss_seidel import GaussSeidel
from ..algorithms.jacobi import Jacobi
from ..observers.recording import Recording
from ..fmi.fmi2 import Fmi2Slave
from ..fmi.fmi3 import Fmi3Slave
from ..fmi.slave import WARNING
from ..native_build import compile_cached

SOURCE = Path(__file__).with_name("native_loop.c")
# Ctrl-C, SIGTERM and the progress bar are served between calls: a call runs at most CHUNK steps and about
# CALL_S seconds at the rate the previous call measured (the first runs one step, and each limit is at most
# GROWTH times the last), so that slow FMUs too return well within a supervisor's grace time
# (supervise.GRACE_S) and the run closes in order
CHUNK, GROWTH, CALL_S = 1 << 16, 16, 0.1
SUPPORTED_TYPES = ("Real", "Integer", "Boolean")

OP_XFER_REAL, OP_XFER_INT32, OP_SET, OP_STEP, OP_GET, OP_PUBLISH, OP_SET3, OP_GET3, OP_STEP3 = range(1, 10)
GATHER_F64, GATHER_I32, GATHER_BITS64 = 1, 2, 3
DONE, OP_FAILED, SAMPLE_FAILED, BLOCK_FULL, NONFINITE, STEP3_LOOK = range(6)
# what the loop reports as it goes (cm_loop's last fields): time reached, time of the last row, rows in the
# block, component whose FMI call is in progress (-1: none)
PROGRESS_SLOTS = ("time_reached", "last_row", "rows", "busy")


class _Op(Structure):
    _fields_ = [("kind", c_longlong), ("comp", c_longlong), ("every", c_longlong), ("phase", c_longlong),
                ("fn", c_void_p), ("inst", c_void_p), ("vr", c_void_p), ("n", c_longlong), ("dst", c_void_p),
                ("src", c_void_p), ("idx", c_void_p), ("factor", c_void_p), ("offset", c_void_p), ("h", c_double),
                ("nvalues", c_longlong), ("no_set_prior", c_longlong), ("event", c_void_p), ("terminate", c_void_p),
                ("early", c_void_p), ("last", c_void_p)]


class _Gather(Structure):
    _fields_ = [("kind", c_longlong), ("src", c_void_p), ("pos", c_void_p), ("n", c_longlong), ("col", c_longlong)]


class _Loop(Structure):
    _fields_ = [("start", c_double), ("h", c_double), ("ops", POINTER(_Op)), ("n_ops", c_longlong),
                ("samples", POINTER(_Op)), ("n_samples", c_longlong), ("every", c_longlong), ("steps", c_longlong),
                ("block", c_void_p), ("block_rows", c_longlong), ("ncols", c_longlong), ("fill", c_longlong),
                ("gathers", POINTER(_Gather)), ("n_gathers", c_longlong), ("check", c_void_p),
                ("n_check", c_longlong), ("counts", c_void_p), ("n", c_longlong), ("code", c_longlong),
                ("op", c_longlong), ("status", c_longlong), ("time_reached", c_void_p), ("last_row", c_void_p),
                ("rows", c_void_p), ("busy", c_void_p)]


@functools.cache
def library():
    """(the loaded library, None) or (None, why it is not available)."""
    target, why = compile_cached(SOURCE, "native_loop", "native-loop", ["-O2", "-ffp-contract=off", "-fPIC", "-shared"],
                                 what="the native loop")
    if target is None:
        return None, why
    # PyDLL: the GIL stays held, as for the master's own FMI calls (fmpy_adapter.Library.raw)
    lib = ctypes.PyDLL(str(target))
    lib.cm_run.argtypes = [POINTER(_Loop), c_longlong, c_longlong, c_longlong, ctypes.c_int]
    lib.cm_run.restype = ctypes.c_int
    return lib, None


def _addr(x) -> int | None:
    if x is None:
        return None
    if isinstance(x, np.ndarray):
        assert x.flags.c_contiguous
        return x.ctypes.data
    return ctypes.cast(x, c_void_p).value


def _fmi3(slave) -> bool:
    return isinstance(slave, Fmi3Slave)


def _why_not_component(slave, rt, i) -> str | None:
    ports = rt.write_ports[i] + rt.read_ports[i] + rt.sample_ports[i]
    if type(slave) is Fmi2Slave and slave.raw_step is not None:
        bad = sorted({t for t, _ in ports} - set(SUPPORTED_TYPES))
        if bad:
            return f"component {slave.name} exchanges {', '.join(bad)} values"
    elif type(slave) is Fmi3Slave:
        if slave.event_mode or slave.early_return or slave.terminate_requested:
            return f"component {slave.name} uses FMI 3.0 event mode or early return"
        if any(t != "Real" or port.extra is not None for t, port in ports):
            return f"component {slave.name} exchanges FMI 3.0 values other than Float64"
    else:
        return f"component {slave.name} is not a native FMI 2.0 or 3.0 co-simulation FMU"
    if any(maps for *_, maps in rt.xfer[i]):
        return f"component {slave.name} has inputs with value maps"
    return None


def why_not(ex) -> str | None:
    """None when the native loop can run this execution, else the reason it cannot (for run.json)."""
    if ex.manipulators:
        return "manipulators act before every step"
    others = [ob for ob in ex.observers if ob is not ex.recording]
    if others:
        names = sorted({getattr(ob, "annotation_type", "") or getattr(ob, "name", "") or type(ob).__name__
                        for ob in others})
        return f"observers look at every step: {', '.join(names)}"
    rec = ex.recording
    # a subclass may look at every step; a supervised child's lets the loop report its progress instead
    if type(rec) is not Recording and getattr(rec, "native_progress", None) is None:
        return f"the recording ({type(rec).__name__}) looks at every step"
    if rec.has_object_columns or rec.block.dtype != np.float64:
        return "the recording has String or Binary columns"
    if ex.algorithm.threads > 1:
        return "threads: the doSteps run concurrently in Python threads"
    # the two fixed sequences of FMI calls themselves (a subclass may step otherwise); feeds_inputs: extrapolated
    # (globally or per output) or interpolated inputs, a step the C loop does not know
    if type(ex.algorithm) not in (Jacobi, GaussSeidel) or ex.algorithm.feeds_inputs:
        return f"the {ex.algorithm.name} algorithm's step is not a fixed sequence of FMI calls"
    rt = ex.rt
    for i, slave in enumerate(rt.slaves):
        if rt.active[i]:
            reason = _why_not_component(slave, rt, i)
            if reason:
                return reason
    lib, reason = library()
    return reason


class _Program:
    """One master step as C operations, for the current set of active components; ``what[k]`` says how a
    failure of operation k is reported, as compiled.py reports it."""

    def __init__(self, ex):
        rt, alg = ex.rt, ex.algorithm
        self.keep = []               # every array and ctypes object the C side points into
        ops, what, tail = [], [], []
        gs = alg.gauss_seidel
        for i in alg.order:
            if not rt.active[i]:
                continue
            slave, k = rt.slaves[i], rt.multiple[i]
            inst = slave.c
            for t, out, src, view, f, o, _ in rt.xfer[i]:
                kind = OP_XFER_REAL if t == "Real" else OP_XFER_INT32
                ops.append(self._op(kind, i, k, 0, n=len(src), dst=view, src=out, idx=src,
                                    factor=f, offset=o if f is not None else None))
                what.append(None)
            for t, port in rt.write_ports[i]:
                ops.append(self._port_op("Set", slave, i, k, t, port))
                what.append(("setting inputs", 0.0))
            ops.append(self._step_op(slave, i, k, alg.h * k))
            what.append(("doStep", 0.0))
            gets = [(self._port_op("Get", slave, i, k, t, port), ("getting outputs", alg.h * k))
                    for t, port in rt.read_ports[i]]
            if gs:
                ops += [g for g, _ in gets]
                what += [w for _, w in gets]
            else:
                tail += gets
            for buf, view in rt.staging[i] or ():
                tail.append((self._op(OP_PUBLISH, i, k, 1, n=buf.nbytes, dst=view, src=buf), None))
        ops += [op for op, _ in tail]
        what += [w for _, w in tail]
        self.what = what
        samples, self.sample_what = [], []
        for i, slave in enumerate(rt.slaves):
            if rt.active[i]:
                for t, port in rt.sample_ports[i]:
                    samples.append(self._port_op("Get", slave, i, 1, t, port))
                    self.sample_what.append((i, f"getting recorded outputs ({t})"))
        self.ops = (_Op * max(1, len(ops)))(*ops)
        self.samples = (_Op * max(1, len(samples)))(*samples)
        self.n_ops, self.n_samples = len(ops), len(samples)

    def _port_op(self, op, slave, i, every, typ, port):
        """A getter or setter of one port (``op`` "Get" or "Set")."""
        if _fmi3(slave):
            return self._op(OP_GET3 if op == "Get" else OP_SET3, i, every, 0, fn=slave.raw_function(f"fmi3{op}Float64"),
                            inst=slave.c, vr=port.vrs, n=port.n, dst=port.buf, nvalues=len(port.buf))
        return self._op(OP_GET if op == "Get" else OP_SET, i, every, 0, fn=slave.raw_function(f"fmi2{op}{typ}"),
                        inst=slave.c, vr=port.vrs, n=port.n, dst=port.buf)

    def _step_op(self, slave, i, k, h):
        if not _fmi3(slave):
            return self._op(OP_STEP, i, k, 0, fn=slave.raw_function("fmi2DoStep"), inst=slave.c, h=h)
        cells = event, terminate, early, last = slave.step_cells
        self.keep.append(cells)
        return self._op(OP_STEP3, i, k, 0, fn=slave.raw_function("fmi3DoStep"), inst=slave.c, h=h,
                        no_set_prior=int(not slave.may_roll_back), event=ctypes.addressof(event),
                        terminate=ctypes.addressof(terminate), early=ctypes.addressof(early),
                        last=ctypes.addressof(last))

    def _op(self, kind, comp, every, phase, fn=None, inst=None, vr=None, n=0, dst=None, src=None, idx=None,
            factor=None, offset=None, h=0.0, nvalues=0, no_set_prior=0, event=None, terminate=None, early=None,
            last=None):
        for x in (fn, vr, dst, src, idx, factor, offset):
            if x is not None:
                self.keep.append(x)
        return _Op(kind, comp, every, phase, _addr(fn), inst, _addr(vr), n, _addr(dst), _addr(src), _addr(idx),
                   _addr(factor), _addr(offset), h, nvalues, no_set_prior, event, terminate, early, last)


class NativeLoop:
    """Runs an execution's steps in C between the points where Python must look (see the module's doc)."""
    name = "native_loop"

    def __init__(self, ex, lib):
        self.ex, self.lib = ex, lib
        rt, rec = ex.rt, ex.recording
        self.counts = np.zeros(len(rt.names), dtype=np.int64)
        self.steps_run = 0
        self.chunk = 1
        self._program = None
        self._active = None
        L = self.L = _Loop()
        L.start, L.h = ex.settings.start, ex.algorithm.h
        L.every, L.steps = rec.every, rec.steps or 0
        L.ncols = rec.block.shape[1]
        L.block_rows = rec.block_rows
        gathers = []
        for out, pos, a, b in rec.gather:
            kind = GATHER_F64 if out.dtype == np.float64 else GATHER_BITS64 if out.dtype.itemsize == 8 else GATHER_I32
            gathers.append(_Gather(kind, out.ctypes.data, pos.ctypes.data, len(pos), a))
        self._gather_arrays = [(out, pos) for out, pos, _, _ in rec.gather]     # kept alive for the C side
        self._gathers = (_Gather * max(1, len(gathers)))(*gathers)
        L.gathers, L.n_gathers = self._gathers, len(gathers)
        if not ex.options.allow_nonfinite and len(rt.out["Real"]):
            L.check, L.n_check = rt.out["Real"].ctypes.data, len(rt.out["Real"])
        L.counts = self.counts.ctypes.data
        self._bind_progress(rec)

    def _pace(self, steps: int, seconds: float) -> None:
        if steps > 0:
            self.chunk = max(1, min(CHUNK, GROWTH * self.chunk, int(steps * CALL_S / max(seconds, 1e-9))))

    def _bind_progress(self, rec):
        """The C loop keeps a supervised child's progress (supervise.py) as after_step and sample keep it on the
        Python path: such a recording offers one-value views of its shared header; anything else gets scratch."""
        offer = getattr(rec, "native_progress", None)
        slots = offer() if offer is not None else {}
        scratch = np.full(len(PROGRESS_SLOTS), -1.0)
        self._progress = [slots.get(name, scratch[k:k + 1]) for k, name in enumerate(PROGRESS_SLOTS)]
        for name, view in zip(PROGRESS_SLOTS, self._progress):      # kept alive for the C side
            setattr(self.L, name, _addr(view))

    def _bind(self):
        rt = self.ex.rt
        # FMI 3.0's noSetFMUStatePriorToCurrentPoint changes once someone saves a state (Execution.save_state)
        active = (tuple(rt.active), tuple(getattr(s, "may_roll_back", False) for s in rt.slaves))
        if self._program is None or active != self._active:
            self._program = _Program(self.ex)
            self._active = active
        p = self._program
        self.L.ops, self.L.n_ops = p.ops, p.n_ops
        self.L.samples, self.L.n_samples = p.samples, p.n_samples
        return p

    def _call(self, n0, n1, op0=0, rest_only=False):
        """Steps n0 .. n1-1 in C. The master's count of steps, rows and calls is brought up to date with what
        the loop did before an interrupt is let through, so that run.json and the rows kept agree."""
        ex, L = self.ex, self.L
        rec = ex.recording
        with interrupts.deferred():
            L.block, L.fill = rec.block.ctypes.data, rec.fill      # the recording's own: flushing resets its fill
            code = self.lib.cm_run(ctypes.byref(L), n0, n1, op0, int(rest_only))
            rec.fill = L.fill
            self.steps_run += L.n - n0
            done = self.counts.nonzero()[0]
            for i in done:
                ex.rt.do_step_calls[i] += int(self.counts[i])
            self.counts[done] = 0
            ex.metadata["native_loop"]["steps"] = self.steps_run
            if not rest_only:        # the rest of a step that ends the run: Python does what follows it
                ex.n = L.n           # steps completed, or the step in progress after a failure
                if L.n > 0:
                    ex.metadata["last_time"] = ex.settings.start + L.n * ex.settings.step
        return code

    def advance(self, n: int, stop: int, bar=None) -> None:
        """Steps n .. stop-1 (fewer when the run ends early or fails); ``ex.n`` and run.json's last time follow
        as in the Python path, also when this raises."""
        ex = self.ex
        rt, meta, st = ex.rt, ex.metadata, ex.settings
        start, h = st.start, st.step
        p = self._bind()
        op0, ending = 0, False      # ending: an FMU asked to terminate in step n; its rest runs, then Python looks
        while n < stop:
            if ending:
                code = self._call(n, n + 1, op0, rest_only=True)
            else:
                t0 = time.perf_counter()
                code = self._call(n, min(stop, n + self.chunk), op0)
                self._pace(self.L.n - n, time.perf_counter() - t0)
            op0 = 0
            done = self.L.n
            if bar is not None:
                bar.update(done - n)
            if ending and code == DONE:
                self._after_terminating_step(n)
                return
            n = done
            if code == DONE:
                continue
            if code == BLOCK_FULL:
                ex.recording.flush()
                if self.L.status:
                    raise rt.nonfinite_error(start + n * h)
                continue
            if code == NONFINITE:
                raise rt.nonfinite_error(start + n * h)
            if code == SAMPLE_FAILED:
                i, what = p.sample_what[self.L.op]
                meta["last_time"] = start + (n + 1) * h
                raise rt.slaves[i].fail(what, self.L.status, start + (n + 1) * h)
            # OP_FAILED or STEP3_LOOK: operation k of step n; the step goes on from k + 1 unless this raises
            k, status = self.L.op, self.L.status
            op, t = p.ops[k], start + n * h
            slave = rt.slaves[op.comp]
            if code == STEP3_LOOK:
                status = slave.after_do_step(t, op.h, status)
            call, dt = p.what[k]
            if status > WARNING:
                if call != "doStep" or not rt.ends_run_on_request(op.comp, status):
                    raise slave.fail(call, status, t + dt if dt else t)
                ending = True
            op0 = k + 1

    def _after_terminating_step(self, n: int) -> None:
        """What the Python path does after step n when an FMU asked to terminate in it."""
        ex, rt, meta = self.ex, self.ex.rt, self.ex.metadata
        start, h = ex.settings.start, ex.settings.step
        t1 = start + (n + 1) * h
        meta["last_time"] = t1
        for ob in ex.observers:
            ob.after_step(n, start + n * h, t1)
        ex.n = n + 1
        if self.L.check and rt.out["Real"].dot(rt.real_zeros) != 0.0:
            raise rt.nonfinite_error(t1)
        meta["ended_early"] = {"time": t1, "reason": rt.stop_reason}


class NativeDriver:
    """The native loop as a step driver (``base.StepDriver``)."""
    name = NativeLoop.name

    def why_not(self, ex) -> str | None:
        return why_not(ex)

    def bind(self, ex) -> NativeLoop:
        return NativeLoop(ex, library()[0])


NATIVE = NativeDriver()
