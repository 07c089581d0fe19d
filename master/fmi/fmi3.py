"""FMI 3.0 co-simulation instances; variables of one base type may span several concrete FMI 3 types.

Event mode and early return (FMI 3.0 sections 4.2.3 and 4.3): an FMU that offers event mode
(``hasEventMode``) is instantiated with eventModeUsed, and one that may return early from a step
(``mightReturnEarlyFromDoStep``) with earlyReturnAllowed. The master's grid stays fixed: the events an FMU
reports are handled within the communication step that contains them, by this component alone.

* fmi3DoStep reports eventHandlingNeeded: Event Mode at lastSuccessfulTime, fmi3UpdateDiscreteStates until
  the FMU needs no new discrete states, then Step Mode again (an event at the end of the step is handled
  there before the master reads the outputs).
* fmi3DoStep returned early (lastSuccessfulTime < t + h, after an event or not): the rest of the step is
  another fmi3DoStep from lastSuccessfulTime to t + h, so that the component reaches the master's
  communication point like every other. Its inputs stay those of the step's start throughout (the step's
  zero-order hold); the other components see what changed at the event at the next communication point.
* terminateSimulation, from fmi3DoStep or from the event iteration, ends the run after this step (as
  before). When it comes at an event inside the step, the FMU stays at that time and its outputs read at the
  step's end are those of the event; the log says so.

Clocks (scheduled execution, clocked co-simulation) are not supported.
"""
from __future__ import annotations

import ctypes
from ctypes import POINTER, byref, c_char_p, c_double, c_size_t, c_uint, c_uint8

import numpy as np

from ..errors import FmuError
from .events import settle
from .fmpy_adapter import fmi3_callbacks, load_library
from .native import NativeSlave
from .slave import DISCARD, ERROR, OK, WARNING, Port, array_shape


def _ptr(arr: np.ndarray, ctype):
    return arr.ctypes.data_as(POINTER(ctype))


def _binary_args(values) -> tuple:
    """FMI 3 Binary arguments for ``values`` (bytes): the sizes and the pointers. The pointers lead into the
    bytes objects themselves (no copy), which the caller keeps alive for the call."""
    n = len(values)
    return (c_size_t * n)(*map(len, values)), (POINTER(c_uint8) * n)(*(ctypes.cast(c_char_p(b), POINTER(c_uint8))
                                                                       for b in values))


class Fmi3Slave(NativeSlave):
    """FMI 3.0 co-simulation; variables of one base type may span several concrete FMI 3 types."""
    GET_STATE, SET_STATE, FREE_STATE = "fmi3GetFMUState", "fmi3SetFMUState", "fmi3FreeFMUState"
    TERMINATE, FREE_INSTANCE = "fmi3Terminate", "fmi3FreeInstance"
    # set from the FMU's capabilities at instantiation (model exchange, which inherits from here, uses neither)
    event_mode = early_return = False

    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        self.lib = load_library("fmi3cs", name, fmu, shown_as, fmu.md.coSimulation.modelIdentifier)
        self.logging_on = logging_on
        self._f = self.lib
        # fmpy spells the attribute the FMI 2 way for FMI 3 too
        self.can_save_state = bool(getattr(fmu.md.coSimulation, "canGetAndSetFMUstate", False))
        self.c = None
        by_vr = {v.valueReference: v for v in fmu.md.modelVariables}
        self._vtype = {vr: v.type for vr, v in by_vr.items()}
        # values per variable: an array moves all its elements (row-major) under its one value reference
        self._nvalues = {vr: int(np.prod(array_shape(v, by_vr))) for vr, v in by_vr.items()}

    def instantiate(self):
        self._log_cb, self._iu_cb = fmi3_callbacks(self._logger_fn())
        resources = str(self.fmu.unzip_dir / "resources") + "/"
        cs = self.fmu.md.coSimulation
        self.event_mode = bool(getattr(cs, "hasEventMode", False))
        self.early_return = bool(getattr(cs, "mightReturnEarlyFromDoStep", False))
        self.terminate_requested = False
        self.counts = dict.fromkeys(("events", "early_returns"), 0)
        comp = self._instantiate(resources)
        if not comp and self.event_mode:
            # some FMUs declare hasEventMode but refuse eventModeUsed (Reference FMU Roberts): without event mode
            # an FMU handles its events itself, which FMI 3.0 requires of every co-simulation FMU
            refusal = self.log.pop_error(self.name)
            self.event_mode = False
            comp = self._instantiate(resources)
            if comp:
                self.log.message(self.name, "warning", "declares hasEventMode but refused eventModeUsed"
                                 + (f" ({refusal})" if refusal else "") + ": instantiated without event mode")
        if not comp:
            raise self.fail("fmi3InstantiateCoSimulation", ERROR)
        self.c = comp
        self.lib.bind_instance(comp)
        self.instantiated = True
        self._last_successful = c_double()
        self._flags = (ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool())

    def _instantiate(self, resources: str):
        return self._f["fmi3InstantiateCoSimulation"](
            self.name.encode(), self.fmu.md.guid.encode(), resources.encode(), False, self.logging_on,
            self.event_mode, self.early_return, None, 0, None, self._log_cb, self._iu_cb)

    def setup(self, start, stop, tolerance=None):
        self._start, self._stop, self._tol = start, stop, tolerance

    def enter_init(self, t):
        st = self._f["fmi3EnterInitializationMode"](self.c, self._tol is not None, self._tol or 0.0, self._start,
                                                    self._stop is not None, self._stop or 0.0)
        self.check("fmi3EnterInitializationMode", st, t)

    def exit_init(self, t):
        self.check("fmi3ExitInitializationMode", self._f["fmi3ExitInitializationMode"](self.c), t)
        self.initialized = True
        if self.event_mode:          # with eventModeUsed the FMU leaves initialization in Event Mode
            self.terminate_requested = self._event_iteration(t)

    _CT = {"Float64": c_double, "Float32": ctypes.c_float, "Int8": ctypes.c_int8, "UInt8": ctypes.c_uint8,
           "Int16": ctypes.c_int16, "UInt16": ctypes.c_uint16, "Int32": ctypes.c_int32, "UInt32": ctypes.c_uint32,
           "Int64": ctypes.c_int64, "UInt64": ctypes.c_uint64, "Enumeration": ctypes.c_int64,
           "Boolean": ctypes.c_bool}

    def _fn(self, op, t3):
        return self._f[f"fmi3{op}{'Int64' if t3 == 'Enumeration' else t3}"]

    def set_value(self, typ, vr, value):
        """One variable: a scalar, or every element of an array (a sequence, row-major)."""
        t3 = self._vtype[vr]
        vrs = (c_uint * 1)(vr)
        values = list(value) if isinstance(value, (list, tuple)) else [value]
        n = len(values)
        if t3 == "String":
            return self._f["fmi3SetString"](self.c, vrs, 1, (c_char_p * n)(*(str(x).encode() for x in values)), n)
        if t3 == "Binary":
            data = [bytes(x) for x in values]
            return self._f["fmi3SetBinary"](self.c, vrs, 1, *_binary_args(data), n)
        return self._fn("Set", t3)(self.c, vrs, 1, (self._CT[t3] * n)(*values), n)

    def _collapse(self, vrs) -> np.ndarray:
        """The master lists an array's value reference once per element; FMI 3 wants it once per variable."""
        out, k = [], 0
        while k < len(vrs):
            vr = int(vrs[k])
            out.append(vr)
            k += self._nvalues[vr]
        return np.array(out, dtype=np.uint32)

    def make_port(self, typ, vrs, buf):
        """Split the references by concrete FMI 3 type; each group gets its own typed scratch array."""
        per_value = np.asarray(vrs, dtype=np.uint32)
        port = Port(self._collapse(per_value), buf, c_double if typ == "Real" else None)
        groups = []
        for t3 in sorted({self._vtype[int(v)] for v in port.vrs}):
            idx = np.array([i for i, v in enumerate(per_value) if self._vtype[int(v)] == t3], dtype=np.intp)
            g_vrs = self._collapse(per_value[idx])
            if t3 == "String":
                scratch = (c_char_p * len(idx))()
            elif t3 == "Binary":         # the sizes and the pointers the FMU fills in
                scratch = ((c_size_t * len(idx))(), (POINTER(c_uint8) * len(idx))())
            else:
                scratch = (self._CT[t3] * len(idx))()
            groups.append((t3, idx, len(g_vrs), _ptr(g_vrs, c_uint), scratch, g_vrs))
        # the common all-Float64 case moves the master's buffer directly
        port.extra = None if (typ == "Real" and len(groups) == 1 and groups[0][0] == "Float64") else groups
        return port

    def get_port(self, typ, port) -> int:
        if port.extra is None:
            return self._f["fmi3GetFloat64"](self.c, port.vr_ptr, port.n, port.buf_ptr, len(port.buf))
        worst = OK
        for t3, idx, nvr, vr_ptr, scratch, _ in port.extra:
            n = len(idx)
            if t3 == "String":
                st = self._f["fmi3GetString"](self.c, vr_ptr, nvr, scratch, n)
                for k, i in enumerate(idx):
                    port.buf[i] = scratch[k].decode("utf-8", "replace") if scratch[k] else ""
            elif t3 == "Binary":
                sizes, pointers = scratch
                st = self._f["fmi3GetBinary"](self.c, vr_ptr, nvr, sizes, pointers, n)
                # the FMU's memory is only valid until its next call: copy the bytes out now
                for k, i in enumerate(idx):
                    port.buf[i] = ctypes.string_at(pointers[k], sizes[k]) if pointers[k] else b""
            else:
                st = self._fn("Get", t3)(self.c, vr_ptr, nvr, scratch, n)
                port.buf[idx] = np.ctypeslib.as_array(scratch) if t3 != "Boolean" else [bool(x) for x in scratch]
            worst = max(worst, st)
        return worst

    def set_port(self, typ, port) -> int:
        if port.extra is None:
            return self._f["fmi3SetFloat64"](self.c, port.vr_ptr, port.n, port.buf_ptr, len(port.buf))
        worst = OK
        for t3, idx, nvr, vr_ptr, scratch, _ in port.extra:
            n = len(idx)
            if t3 == "String":
                scratch[:] = [str(port.buf[i]).encode() for i in idx]
                st = self._f["fmi3SetString"](self.c, vr_ptr, nvr, scratch, n)
            elif t3 == "Binary":
                data = [bytes(port.buf[i]) for i in idx]
                st = self._f["fmi3SetBinary"](self.c, vr_ptr, nvr, *_binary_args(data), n)
            else:
                vals = port.buf[idx]
                scratch[:] = [bool(x) for x in vals] if t3 == "Boolean" else vals.tolist()
                st = self._fn("Set", t3)(self.c, vr_ptr, nvr, scratch, n)
            worst = max(worst, st)
        return worst

    _may_roll_back = False

    @property
    def may_roll_back(self) -> bool:
        """Whether the master may set a state saved before the current point (then every fmi3DoStep is called
        with noSetFMUStatePriorToCurrentPoint false); true from the first ``save_state`` on."""
        return self._may_roll_back

    @property
    def step_cells(self) -> tuple:
        """The ctypes cells fmi3DoStep writes: (eventHandlingNeeded, terminateSimulation, earlyReturn,
        lastSuccessfulTime). A step driver that calls fmi3DoStep itself passes these and hands the status to
        ``after_do_step``, which reads them."""
        return (*self._flags, self._last_successful)

    @property
    def last_successful_time(self) -> float:
        """The lastSuccessfulTime of the last fmi3DoStep."""
        return self._last_successful.value

    def save_state(self, t=None):
        self._may_roll_back = True
        return super().save_state(t)

    def _event_iteration(self, t) -> bool:
        """In Event Mode at t: update the discrete states until settled, then back to Step Mode; True when the
        FMU asks to terminate the simulation (it then stays in Event Mode, from which it may terminate)."""
        terminate, _ = settle(self, self.lib.obj.updateDiscreteStates, "fmi3UpdateDiscreteStates", t)
        if not terminate:
            self.check("fmi3EnterStepMode", self._f["fmi3EnterStepMode"](self.c), t)
        return terminate

    def do_step(self, t, h) -> int:
        if self.terminate_requested:
            return DISCARD
        return self.after_do_step(t, h, self._call_do_step(t, h))

    def _call_do_step(self, t, h) -> int:
        event, terminate, early = self._flags
        # noSetFMUStatePriorToCurrentPoint: not when the master may roll back to the start of its step, which
        # lies before the continuation of an early return
        return self._f["fmi3DoStep"](self.c, t, h, not self._may_roll_back, byref(event), byref(terminate),
                                     byref(early), byref(self._last_successful))

    def after_do_step(self, t, h, st) -> int:
        """The rest of ``do_step`` once its first fmi3DoStep (t, h) returned ``st``, with its flags in
        ``step_cells`` (a step driver may make that first call itself)."""
        end = t + h
        event, terminate, early = self._flags
        last = self._last_successful
        worst = OK
        stalled = 0
        while True:
            worst = max(worst, st)
            if st > WARNING or terminate:
                break
            reached = last.value if early else end
            if event and self.event_mode:
                self.counts["events"] += 1
                self.check("fmi3EnterEventMode", self._f["fmi3EnterEventMode"](self.c), reached)
                if self._event_iteration(reached):
                    terminate.value = True
                    break
            if not early or end - reached <= 1e-12 * max(1.0, abs(end)):
                break
            self.counts["early_returns"] += 1
            # an FMU that keeps returning early without getting anywhere would hang the run
            stalled = stalled + 1 if reached <= t else 0
            if stalled > 100:
                raise FmuError("fmi3DoStep returned early 100 times without getting past this time",
                               file=self.shown_as, element=f"component {self.name}", time=reached)
            t, h = reached, end - reached
            st = self._call_do_step(t, h)
        if terminate:
            self.terminate_requested = True
            if early and last.value < end:
                self.log.message(self.name, "info",
                                 f"asked to terminate the simulation at t={last.value:.17g}, inside the "
                                 f"communication step to {end:.17g}: its outputs there are those of "
                                 f"t={last.value:.17g}")
            # terminateSimulation comes as Discard, so that the master's step tests one number when all is well
            return max(worst, DISCARD)
        return worst

    def asks_to_terminate(self, status: int) -> bool:
        """After do_step returned ``status`` above Warning: whether the FMU asked to end the simulation."""
        return status == DISCARD and self.terminate_requested

    def stats(self) -> dict:
        """With event mode or early return in use: which, and how many events and early returns there were."""
        if not (self.event_mode or self.early_return):
            return {}
        return {"event_mode": self.event_mode, "early_return": self.early_return, **self.counts}
