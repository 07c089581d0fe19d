"""FMU instances behind one small interface, whatever the FMI version or kind.

Value transfer works on contiguous numpy buffers owned by the master: a slave is handed a value
reference array and a buffer slice once (``bind_*``), and each step calls the FMI getter or setter
once per type with pointers computed in advance. Statuses are returned, not raised, so the master
can attach the component and simulation time to the message.
"""
from __future__ import annotations

import ctypes
import functools
import os
from ctypes import POINTER, byref, c_char_p, c_double, c_int, c_uint, c_void_p

import numpy as np

from ..errors import FmuError
from .cache import LoadedFmu
from .logsink import STATUS_LEVEL, STATUS_NAME, LogSink

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4

# Base types the master moves around, and the numpy dtype of their buffers.
BASE_TYPES = ("Real", "Integer", "Boolean", "String")
DTYPES = {"Real": np.float64, "Integer": np.int32, "Boolean": np.int32}

FMI3_TYPE_BASE = {
    "Float64": "Real", "Float32": "Real",
    "Int8": "Integer", "UInt8": "Integer", "Int16": "Integer", "UInt16": "Integer",
    "Int32": "Integer", "UInt32": "Integer", "Int64": "Integer", "UInt64": "Integer",
    "Enumeration": "Integer", "Boolean": "Boolean", "String": "String",
}
FMI2_TYPE_BASE = {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer", "Boolean": "Boolean",
                  "String": "String"}


def base_type(fmi_version: str, var_type: str) -> str | None:
    table = FMI3_TYPE_BASE if fmi_version.startswith("3") else FMI2_TYPE_BASE
    return table.get(var_type)


def load_library(cls, name, fmu, shown_as, model_identifier):
    """Create the fmpy FMU object; fmpy changes the working directory while loading and does not change it
    back when the library fails to load, so the caller's directory is restored here."""
    cwd = os.getcwd()
    try:
        return cls(guid=fmu.md.guid, unzipDirectory=str(fmu.unzip_dir), modelIdentifier=model_identifier,
                   instanceName=name)
    except Exception as exc:
        raise FmuError(f"cannot load the FMU's binary: {' '.join(str(exc).split())}", file=shown_as,
                       element=f"component {name}") from None
    finally:
        os.chdir(cwd)


def _ptr(arr: np.ndarray, ctype):
    return arr.ctypes.data_as(POINTER(ctype))


class Port:
    """A set of value references of one base type bound to a buffer slice of the master."""
    __slots__ = ("vrs", "buf", "n", "vr_ptr", "buf_ptr", "extra")

    def __init__(self, vrs, buf, ctype):
        self.vrs = np.ascontiguousarray(vrs, dtype=np.uint32)
        self.buf = buf
        self.n = len(self.vrs)
        self.vr_ptr = _ptr(self.vrs, c_uint)
        self.buf_ptr = _ptr(buf, ctype) if ctype is not None else None
        self.extra = None


class Slave:
    """Common interface; subclasses implement the FMI calls."""
    kind = "CoSimulation"

    def __init__(self, name: str, fmu: LoadedFmu, log: LogSink, shown_as: str):
        self.name = name
        self.fmu = fmu
        self.log = log
        self.shown_as = shown_as
        self.instantiated = False
        self.initialized = False

    # helpers ----------------------------------------------------------------------------
    def fail(self, call: str, status: int, time: float | None = None) -> FmuError:
        detail = self.log.pop_error(self.name)
        reason = f"{call} returned {STATUS_NAME.get(status, status)}"
        if detail:
            reason += f": {detail}"
        return FmuError(reason, file=self.shown_as, element=f"component {self.name}", time=time)

    def check(self, call: str, status: int, time: float | None = None) -> None:
        if status > WARNING:
            raise self.fail(call, status, time)

    # fast-path operations: bound once after instantiation, then called every step without arguments
    # (getters/setters) or with (t, h) (step); each returns the FMI status
    def bound_get(self, typ, port):
        return functools.partial(self.get_port, typ, port)

    def bound_set(self, typ, port):
        return functools.partial(self.set_port, typ, port)

    def bound_step(self):
        return self.do_step

    # When a slave offers a raw step, the compiled step calls it as raw(c_double(t), c_double(h), 1), sharing
    # one c_double for t among all slaves of a master step (no per-call argument conversion).
    raw_step = None

    def _logger_fn(self):
        sink, name = self.log, self.name

        def log_message(env, instance_name, status, category, message):
            text = message.decode("utf-8", "replace") if message else ""
            cat = category.decode("utf-8", "replace") if category else ""
            if cat.startswith("logStatus") or cat == "logAll":
                cat = ""
            sink.message(name, STATUS_LEVEL.get(status, "info"), text, cat)
        return log_message


class Fmi2Slave(Slave):
    """FMI 2.0 co-simulation through fmpy's library loading, with direct ctypes calls on the hot path."""

    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        from fmpy.fmi2 import FMU2Slave
        self.fmu2 = load_library(FMU2Slave, name, fmu, shown_as, fmu.md.coSimulation.modelIdentifier)
        self.logging_on = logging_on
        f = self.fmu2._functions
        self._f = f
        self.c = None

    def instantiate(self):
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
        from fmpy import calloc, free
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(self._logger_fn())
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        # fmpy's native logger proxy (which would expand printf-style arguments) keeps a single global
        # target, so messages of several instances would all reach the last one; messages are taken verbatim.
        self._callbacks = cb
        uri = (self.fmu.unzip_dir / "resources").as_uri()
        comp = self._f["fmi2Instantiate"](self.name.encode(), self._instantiate_call(), self.fmu.md.guid.encode(),
                                          uri.encode(),
                                          byref(cb), 0, 1 if self.logging_on else 0)
        if not comp:
            raise self.fail("fmi2Instantiate", ERROR)
        self.c = comp
        self.fmu2.component = comp
        self.instantiated = True
        f, c = self._f, comp
        self._do_step = f.get("fmi2DoStep")
        self._get = {"Real": f["fmi2GetReal"], "Integer": f["fmi2GetInteger"], "Boolean": f["fmi2GetBoolean"]}
        self._set = {"Real": f["fmi2SetReal"], "Integer": f["fmi2SetInteger"], "Boolean": f["fmi2SetBoolean"]}

    def _instantiate_call(self):
        return 1  # fmi2CoSimulation

    def setup(self, start, stop, tolerance=None):
        st = self._f["fmi2SetupExperiment"](self.c, 1 if tolerance else 0, tolerance or 0.0, start,
                                             1 if stop is not None else 0, stop if stop is not None else 0.0)
        self.check("fmi2SetupExperiment", st, start)

    def enter_init(self, t):
        self.check("fmi2EnterInitializationMode", self._f["fmi2EnterInitializationMode"](self.c), t)

    def exit_init(self, t):
        self.check("fmi2ExitInitializationMode", self._f["fmi2ExitInitializationMode"](self.c), t)
        self.initialized = True

    # scalar access for start values and inspection
    def set_value(self, typ, vr, value):
        vrs = (c_uint * 1)(vr)
        if typ == "Real":
            st = self._f["fmi2SetReal"](self.c, vrs, 1, (c_double * 1)(value))
        elif typ in ("Integer", "Boolean"):
            st = self._f["fmi2Set" + typ](self.c, vrs, 1, (c_int * 1)(int(value)))
        else:
            st = self._f["fmi2SetString"](self.c, vrs, 1, (c_char_p * 1)(str(value).encode()))
        return st

    # bulk access: a Port is bound once, then moved with one call
    def make_port(self, typ, vrs, buf):
        port = Port(vrs, buf, c_double if typ == "Real" else (c_int if typ != "String" else None))
        if typ == "String":
            port.extra = (c_char_p * port.n)()
        return port

    def get_port(self, typ, port) -> int:
        if typ == "String":
            st = self._f["fmi2GetString"](self.c, port.vr_ptr, port.n, port.extra)
            for i in range(port.n):
                v = port.extra[i]
                port.buf[i] = v.decode("utf-8", "replace") if v is not None else ""
            return st
        return self._get[typ](self.c, port.vr_ptr, port.n, port.buf_ptr)

    def set_port(self, typ, port) -> int:
        if typ == "String":
            port.extra[:] = [str(v).encode() for v in port.buf]
            return self._f["fmi2SetString"](self.c, port.vr_ptr, port.n, port.extra)
        return self._set[typ](self.c, port.vr_ptr, port.n, port.buf_ptr)

    def do_step(self, t, h) -> int:
        return self._do_step(self.c, t, h, 1)

    def _raw(self, name):
        """A fresh function object without argtypes: called with ready ctypes arguments it skips the
        per-argument conversion that fmpy's prototypes (argtypes) perform on every call. It comes from a
        PyDLL view of the same library handle, so the GIL is kept across the call instead of being released
        and re-acquired three times per FMU step (the master is single-threaded; a pythonfmu binary
        re-entering Python from this thread finds the GIL already held, which PyGILState_Ensure allows)."""
        dll = getattr(self, "_pydll", None)
        if dll is None:
            dll = self._pydll = ctypes.PyDLL(self.fmu2.dll._name, handle=self.fmu2.dll._handle)
        return dll[name]

    def bound_get(self, typ, port):
        if typ == "String":
            return super().bound_get(typ, port)
        return functools.partial(self._raw(f"fmi2Get{typ}"), c_void_p(self.c), port.vr_ptr, ctypes.c_size_t(port.n),
                                 port.buf_ptr)

    def bound_set(self, typ, port):
        if typ == "String":
            return super().bound_set(typ, port)
        return functools.partial(self._raw(f"fmi2Set{typ}"), c_void_p(self.c), port.vr_ptr, ctypes.c_size_t(port.n),
                                 port.buf_ptr)

    def bound_step(self):
        f, c = self._do_step, c_void_p(self.c)

        def step(t, h):
            return f(c, t, h, 1)
        return step

    @property
    def raw_step(self):
        return functools.partial(self._raw("fmi2DoStep"), c_void_p(self.c)) if self._do_step is not None else None

    def terminate(self):
        if self.initialized:
            self.initialized = False
            return self._f["fmi2Terminate"](self.c)
        return OK

    def free(self):
        if self.instantiated:
            self.instantiated = False
            self._f["fmi2FreeInstance"](self.c)


class Fmi3Slave(Slave):
    """FMI 3.0 co-simulation; variables of one base type may span several concrete FMI 3 types."""

    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        from fmpy.fmi3 import FMU3Slave
        self.fmu3 = load_library(FMU3Slave, name, fmu, shown_as, fmu.md.coSimulation.modelIdentifier)
        self.logging_on = logging_on
        self._f = self.fmu3._functions
        self.c = None
        self._vtype = {v.valueReference: v.type for v in fmu.md.modelVariables}

    def instantiate(self):
        from fmpy.fmi3 import fmi3IntermediateUpdateCallback, fmi3LogMessageCallback
        fn = self._logger_fn()
        self._log_cb = fmi3LogMessageCallback(lambda env, status, cat, msg: fn(env, None, status, cat, msg))
        self._iu_cb = fmi3IntermediateUpdateCallback()
        resources = str(self.fmu.unzip_dir / "resources") + "/"
        comp = self._f["fmi3InstantiateCoSimulation"](
            self.name.encode(), self.fmu.md.guid.encode(), resources.encode(), False, self.logging_on,
            False, False, None, 0, None, self._log_cb, self._iu_cb)
        if not comp:
            raise self.fail("fmi3InstantiateCoSimulation", ERROR)
        self.c = comp
        self.fmu3.component = comp
        self.instantiated = True
        self._last_successful = c_double()
        self._flags = (ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool())

    def setup(self, start, stop, tolerance=None):
        self._start, self._stop, self._tol = start, stop, tolerance

    def enter_init(self, t):
        st = self._f["fmi3EnterInitializationMode"](self.c, self._tol is not None, self._tol or 0.0, self._start,
                                                    self._stop is not None, self._stop or 0.0)
        self.check("fmi3EnterInitializationMode", st, t)

    def exit_init(self, t):
        self.check("fmi3ExitInitializationMode", self._f["fmi3ExitInitializationMode"](self.c), t)
        self.initialized = True

    _CT = {"Float64": c_double, "Float32": ctypes.c_float, "Int8": ctypes.c_int8, "UInt8": ctypes.c_uint8,
           "Int16": ctypes.c_int16, "UInt16": ctypes.c_uint16, "Int32": ctypes.c_int32, "UInt32": ctypes.c_uint32,
           "Int64": ctypes.c_int64, "UInt64": ctypes.c_uint64, "Enumeration": ctypes.c_int64,
           "Boolean": ctypes.c_bool}

    def _fn(self, op, t3):
        return self._f[f"fmi3{op}{'Int64' if t3 == 'Enumeration' else t3}"]

    def set_value(self, typ, vr, value):
        t3 = self._vtype[vr]
        vrs = (c_uint * 1)(vr)
        if t3 == "String":
            return self._f["fmi3SetString"](self.c, vrs, 1, (c_char_p * 1)(str(value).encode()), 1)
        ct = self._CT[t3]
        return self._fn("Set", t3)(self.c, vrs, 1, (ct * 1)(value), 1)

    def make_port(self, typ, vrs, buf):
        """Split the references by concrete FMI 3 type; each group gets its own typed scratch array."""
        port = Port(vrs, buf, c_double if typ == "Real" else None)
        groups = []
        for t3 in sorted({self._vtype[int(v)] for v in port.vrs}):
            idx = np.array([i for i, v in enumerate(port.vrs) if self._vtype[int(v)] == t3], dtype=np.intp)
            g_vrs = np.ascontiguousarray(port.vrs[idx])
            if t3 == "String":
                scratch = (c_char_p * len(idx))()
            else:
                scratch = (self._CT[t3] * len(idx))()
            groups.append((t3, idx, g_vrs, _ptr(g_vrs, c_uint), scratch))
        # the common all-Float64 case moves the master's buffer directly
        port.extra = None if (typ == "Real" and len(groups) == 1 and groups[0][0] == "Float64") else groups
        return port

    def get_port(self, typ, port) -> int:
        if port.extra is None:
            return self._f["fmi3GetFloat64"](self.c, port.vr_ptr, port.n, port.buf_ptr, port.n)
        worst = OK
        for t3, idx, g_vrs, vr_ptr, scratch in port.extra:
            n = len(idx)
            if t3 == "String":
                st = self._f["fmi3GetString"](self.c, vr_ptr, n, scratch, n)
                for k, i in enumerate(idx):
                    port.buf[i] = scratch[k].decode("utf-8", "replace") if scratch[k] else ""
            else:
                st = self._fn("Get", t3)(self.c, vr_ptr, n, scratch, n)
                port.buf[idx] = np.ctypeslib.as_array(scratch) if t3 != "Boolean" else [bool(x) for x in scratch]
            worst = max(worst, st)
        return worst

    def set_port(self, typ, port) -> int:
        if port.extra is None:
            return self._f["fmi3SetFloat64"](self.c, port.vr_ptr, port.n, port.buf_ptr, port.n)
        worst = OK
        for t3, idx, g_vrs, vr_ptr, scratch in port.extra:
            n = len(idx)
            if t3 == "String":
                scratch[:] = [str(port.buf[i]).encode() for i in idx]
                st = self._f["fmi3SetString"](self.c, vr_ptr, n, scratch, n)
            else:
                vals = port.buf[idx]
                scratch[:] = [bool(x) for x in vals] if t3 == "Boolean" else vals.tolist()
                st = self._fn("Set", t3)(self.c, vr_ptr, n, scratch, n)
            worst = max(worst, st)
        return worst

    def do_step(self, t, h) -> int:
        a, b, c = self._flags
        return self._f["fmi3DoStep"](self.c, t, h, True, byref(a), byref(b), byref(c), byref(self._last_successful))

    def terminate(self):
        if self.initialized:
            self.initialized = False
            return self._f["fmi3Terminate"](self.c)
        return OK

    def free(self):
        if self.instantiated:
            self.instantiated = False
            self._f["fmi3FreeInstance"](self.c)
