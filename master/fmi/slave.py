"""The one interface every FMU instance offers the master, whatever the FMI version, kind or binding.

Value transfer works on contiguous numpy buffers owned by the master: a slave is handed a value reference
array and a buffer slice once (``make_port``), and each step moves the whole port with one call. Statuses
are returned, not raised, so that the master can attach the component and the simulation time to the
message (``fail``). The life cycle is FMI's: instantiate, setup, enter/exit initialization, do_step ...,
terminate, free.
"""
from __future__ import annotations

import abc
import functools

import numpy as np

from ..errors import FmuError
from .cache import LoadedFmu
from .logsink import STATUS_LEVEL, STATUS_NAME, LogSink

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4

# Base types the master moves around, and the numpy dtype of their buffers. A base type is a buffer: every
# FMI type whose values it holds exactly goes there. "Integer" (int32) keeps FMI 2.0 Integer and FMI 3.0 types
# up to Int32 where they always were (the hot path and its results unchanged); FMI 3.0 UInt32 and Int64 need
# "Int64" (int64 holds every UInt32), UInt64 its own "UInt64". Two more buffers rather than one per FMI type:
# a slave moves each buffer with one port, so fewer buffers mean fewer calls per step. String and FMI 3.0
# Binary (bytes) are object buffers of their own, which a Real/Integer-only system never touches.
BASE_TYPES = ("Real", "Integer", "Int64", "UInt64", "Boolean", "String", "Binary")
DTYPES = {"Real": np.float64, "Integer": np.int32, "Int64": np.int64, "UInt64": np.uint64, "Boolean": np.int32}
INTEGER_BASES = ("Integer", "Int64", "UInt64")
# the buffers of Python objects and the value an empty slot holds
OBJECT_FILL = {"String": "", "Binary": b""}

FMI3_TYPE_BASE = {
    "Float64": "Real", "Float32": "Real",
    "Int8": "Integer", "UInt8": "Integer", "Int16": "Integer", "UInt16": "Integer",
    "Int32": "Integer", "UInt32": "Int64", "Int64": "Int64", "UInt64": "UInt64",
    "Enumeration": "Integer", "Boolean": "Boolean", "String": "String", "Binary": "Binary",
}
FMI2_TYPE_BASE = {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer", "Boolean": "Boolean",
                  "String": "String"}


def array_shape(v, by_vr: dict) -> tuple[int, ...]:
    """An FMI 3.0 array variable's dimensions (``()`` for a scalar): a fixed ``start`` or the start value of the
    structural parameter ``valueReference`` names (``by_vr``: value reference -> model variable)."""
    return tuple(int(d.start) if d.start is not None else int(by_vr[d.valueReference].start)
                 for d in getattr(v, "dimensions", None) or ())


def new_buffer(typ: str, size: int) -> np.ndarray:
    """A zeroed buffer of the base type ``typ`` (empty strings or bytes for the object buffers)."""
    if typ in OBJECT_FILL:
        return np.full(size, OBJECT_FILL[typ], dtype=object)
    return np.zeros(size, dtype=DTYPES[typ])


def base_type(fmi_version: str, var_type: str) -> str | None:
    table = FMI3_TYPE_BASE if fmi_version.startswith("3") else FMI2_TYPE_BASE
    return table.get(var_type)


#: added by ``Slave.bound_cycle`` to a setter's status: the inputs failed, the step was not done
SET_FAILED = 256


class Port:
    """A set of value references of one base type bound to a buffer slice of the master. ``native`` false: a
    slave that calls no C function (in process, a table) gets no ctypes pointers, whose casts were the larger
    part of binding a run's ports."""
    __slots__ = ("vrs", "buf", "n", "vr_ptr", "buf_ptr", "extra")

    def __init__(self, vrs, buf, ctype, native: bool = True):
        self.vrs = np.ascontiguousarray(vrs, dtype=np.uint32)
        self.buf = buf
        self.n = len(self.vrs)
        self.vr_ptr = self.buf_ptr = self.extra = None
        if native:
            from ctypes import POINTER, c_uint
            self.vr_ptr = self.vrs.ctypes.data_as(POINTER(c_uint))
            self.buf_ptr = buf.ctypes.data_as(POINTER(ctype)) if ctype is not None else None


class Slave(abc.ABC):
    """An FMU instance as the master sees it.

    Capabilities (class or instance attributes, checked before a run that needs them starts):
    ``can_save_state`` -- ``save_state``/``restore_state``/``release_state`` work (rollback).
    ``can_interpolate_inputs`` -- ``input_derivatives_setter`` works: the FMU takes time derivatives of its Real
    inputs for the next step (FMI 2.0 canInterpolateInputs, fmi2SetRealInputDerivatives).
    """
    kind = "CoSimulation"
    can_save_state = False
    can_interpolate_inputs = False
    max_output_derivative_order = 0     # ``output_derivatives_getter`` gives derivatives up to this order
    # its bound getters (``bound_get``) may read in initialization mode, where they do what ``get_port`` does (not
    # so for FMI 1.0, whose get_port forgives a refusal before initialization)
    bound_get_in_init = False
    error_status = OK       # the worst status above Discard a call returned: FMI allows no Terminate after Error

    def __init__(self, name: str, fmu: LoadedFmu, log: LogSink, shown_as: str):
        self.name = name
        self.fmu = fmu
        self.log = log
        self.shown_as = shown_as
        self.instantiated = False
        self.initialized = False

    # -- life cycle ---------------------------------------------------------------------------------------
    @abc.abstractmethod
    def instantiate(self) -> None: ...

    @abc.abstractmethod
    def setup(self, start: float, stop: float | None, tolerance: float | None = None) -> None: ...

    @abc.abstractmethod
    def enter_init(self, t: float) -> None: ...

    @abc.abstractmethod
    def exit_init(self, t: float) -> None: ...

    @abc.abstractmethod
    def do_step(self, t: float, h: float) -> int:
        """One communication step from t to t+h; returns the FMI status."""

    @abc.abstractmethod
    def terminate(self) -> int:
        """Only after a successful initialization; a no-op otherwise."""

    @abc.abstractmethod
    def free(self) -> None: ...

    # -- values -------------------------------------------------------------------------------------------
    @abc.abstractmethod
    def set_value(self, typ: str, vr: int, value) -> int:
        """One value (start values, parameters); returns the FMI status."""

    def input_derivatives_setter(self, vrs: list[int], orders: list[int]):
        """A function ``put(values) -> status`` giving the derivatives of order ``orders[j]`` of the Real inputs
        ``vrs[j]`` for the next step (one call per step; only where ``can_interpolate_inputs``)."""
        raise NotImplementedError(f"{self.name} cannot interpolate inputs")

    def output_derivatives_getter(self, vrs: list[int], orders: list[int]):
        """A function ``get() -> (status, values)`` reading the derivatives of order ``orders[j]`` of the Real
        outputs ``vrs[j]`` at the current time (only up to ``max_output_derivative_order``)."""
        raise NotImplementedError(f"{self.name} gives no output derivatives")

    def values_setter(self, typ: str, vrs: list[int]):
        """Optional: a function ``put(values) -> bool`` setting ``vrs`` (start values, parameters) in one call, as
        ``set_value`` one after the other would where nothing else can tell the difference (no code of the FMU runs,
        no status, no message); False: it stored nothing, set them one by one (which reports a failing one). None:
        the slave has no such function for these (asking changes nothing)."""
        return None

    @abc.abstractmethod
    def make_port(self, typ: str, vrs, buf: np.ndarray) -> Port: ...

    @abc.abstractmethod
    def get_port(self, typ: str, port: Port) -> int:
        """Read the port's variables into its buffer."""

    @abc.abstractmethod
    def set_port(self, typ: str, port: Port) -> int:
        """Write the port's buffer to its variables."""

    # -- state (rollback) ---------------------------------------------------------------------------------
    def save_state(self, t: float | None = None):
        """An opaque token for the instance's current state (FMI get FMU state)."""
        raise FmuError("the FMU cannot save and restore its state (canGetAndSetFMUstate is not true)",
                       file=self.shown_as, element=f"component {self.name}", time=t)

    def restore_state(self, token, t: float | None = None) -> None:
        raise FmuError("the FMU cannot save and restore its state", file=self.shown_as,
                       element=f"component {self.name}", time=t)

    def release_state(self, token) -> None:
        """Free a token from ``save_state`` (FMI free FMU state)."""

    # -- fast path: bound once after instantiation, then called every step without arguments (getters and
    # setters) or with (t, h) (step); each returns the FMI status
    def bound_get(self, typ, port):
        return functools.partial(self.get_port, typ, port)

    def bound_set(self, typ, port):
        return functools.partial(self.set_port, typ, port)

    def bound_step(self):
        return self.do_step

    def bound_cycle(self, write_ports, calls: list, index: int):
        """Optional: setting the inputs of ``write_ports`` and the doStep as one callable of (t, h), which also
        counts the step in ``calls[index]``; it returns the step's status, or ``SET_FAILED`` + the setter's
        status when an input could not be set (the step not done). None: the slave has no such shortcut."""
        return None

    # When a slave offers a raw step, the compiled step calls it as raw(c_double(t), c_double(h), 1), sharing
    # one c_double for t among all slaves of a master step (no per-call argument conversion).
    raw_step = None

    def stats(self) -> dict:
        """What the slave's own solver did (model exchange), for run.json; empty when it has none."""
        return {}

    # -- errors -------------------------------------------------------------------------------------------
    def asks_to_terminate(self, status: int) -> bool:
        """After a doStep returned ``status`` above Warning: whether the FMU asks to end the simulation
        (terminateSimulation) instead of failing."""
        return False

    def fail(self, call: str, status: int, time: float | None = None) -> FmuError:
        if status > DISCARD:
            self.error_status = max(self.error_status, status)
        detail = self.log.pop_error(self.name)
        reason = f"{call} returned {STATUS_NAME.get(status, status)}"
        if detail:
            reason += f": {detail}"
        return FmuError(reason, file=self.shown_as, element=f"component {self.name}", time=time)

    def check(self, call: str, status: int, time: float | None = None) -> None:
        if status > WARNING:
            raise self.fail(call, status, time)

    def _logger_fn(self):
        from ..interrupts import keep_interrupts_from_callbacks
        keep_interrupts_from_callbacks()        # a Ctrl-C that lands in this callback must not be lost
        sink, name = self.log, self.name

        def log_message(env, instance_name, status, category, message):
            text = message.decode("utf-8", "replace") if message else ""
            cat = category.decode("utf-8", "replace") if category else ""
            if cat.startswith("logStatus") or cat == "logAll":
                cat = ""
            sink.message(name, STATUS_LEVEL.get(status, "info"), text, cat)
        return log_message
