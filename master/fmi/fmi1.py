"""FMI 1.0 co-simulation instances (CoSimulation_StandAlone and _Tool): fmpy loads the library (its functions
prefixed with the model identifier, see fmpy_adapter.exported_name), the hot path calls the C functions.

FMI 1.0 differs from 2.0 where the master notices: there is no initialization mode (start values and inputs
are set after instantiation, then one fmiInitializeSlave), no FMU state (no rollback), no fmiTerminated status
(a Discarded step is a failure), and fmiBoolean is a char rather than an int.
"""
from __future__ import annotations

import functools
from ctypes import c_char, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import numpy as np

from .fmpy_adapter import fmi1_callbacks, load_library
from .native import NativeSlave
from .slave import ERROR, OK, WARNING, Port

MIME_TYPE = b"application/x-fmu-sharedlibrary"   # the FMU's own binary, not a tool it starts


class Fmi1Slave(NativeSlave):
    """FMI 1.0 co-simulation through fmpy's library loading."""
    TERMINATE, FREE_INSTANCE = "fmi1TerminateSlave", "fmi1FreeSlaveInstance"

    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        self.lib = self._f = load_library("fmi1cs", name, fmu, shown_as, fmu.md.coSimulation.modelIdentifier)
        self.logging_on = logging_on
        self.c = None
        self._start = 0.0
        self._stop: float | None = None

    def instantiate(self):
        # kept referenced: the FMU holds the logger and memory callbacks until fmiFreeSlaveInstance
        self._callbacks = fmi1_callbacks(self._logger_fn())
        location = self.fmu.unzip_dir.as_uri()     # FMI 1.0: the unzipped FMU folder, not its resources
        comp = self._f["fmi1InstantiateSlave"](self.name.encode(), self.fmu.md.guid.encode(), location.encode(),
                                               MIME_TYPE, 0.0, 0, 0, self._callbacks, 1 if self.logging_on else 0)
        if not comp:
            raise self.fail("fmiInstantiateSlave", ERROR)
        self.c = comp
        self.lib.bind_instance(comp)
        self.instantiated = True

    def setup(self, start, stop, tolerance=None):
        """FMI 1.0 takes start and stop time with fmiInitializeSlave (and no tolerance)."""
        self._start, self._stop = start, stop

    def enter_init(self, t):
        """FMI 1.0 has no initialization mode: the master's initialization pass sets parameters and inputs on
        the instantiated slave, which FMI 1.0 allows before fmiInitializeSlave."""

    def exit_init(self, t):
        """fmiInitializeSlave, here rather than in enter_init: FMI 1.0 initializes with the start values and
        inputs set before the call, so it must come after the master's initialization pass has set them (the
        master reads the outputs again after exit_init)."""
        stop_defined = self._stop is not None
        st = self._f["fmi1InitializeSlave"](self.c, t, 1 if stop_defined else 0, self._stop if stop_defined else 0.0)
        self.check("fmiInitializeSlave", st, t)
        self.initialized = True

    # -- values -------------------------------------------------------------------------------------------
    def set_value(self, typ, vr, value):
        vrs = (c_uint * 1)(vr)
        if typ == "Real":
            return self._f["fmi1SetReal"](self.c, vrs, 1, (c_double * 1)(value))
        if typ == "Integer":
            return self._f["fmi1SetInteger"](self.c, vrs, 1, (c_int * 1)(int(value)))
        if typ == "Boolean":
            return self._f["fmi1SetBoolean"](self.c, vrs, 1, (c_char * 1)(1 if value else 0))
        return self._f["fmi1SetString"](self.c, vrs, 1, (c_char_p * 1)(str(value).encode()))

    def make_port(self, typ, vrs, buf):
        """Real and Integer move straight between the master's buffer and the FMU; Boolean (one char per value
        in FMI 1.0, int32 in the master's buffer) and String go through a ctypes array of their own."""
        port = Port(vrs, buf, {"Real": c_double, "Integer": c_int}.get(typ))
        if typ == "Boolean":
            port.extra = (c_char * port.n)()
        elif typ == "String":
            port.extra = (c_char_p * port.n)()
        return port

    def get_port(self, typ, port) -> int:
        st = self._get(typ, port)
        if st > WARNING and not self.initialized:
            # FMI 1.0 defines values only after fmiInitializeSlave and some FMUs refuse getters before it: the
            # initialization pass then keeps what the buffer holds, and the refusal's message is dropped
            self.log.pop_error(self.name)
            return OK
        return st

    def _get(self, typ, port) -> int:
        if typ in ("Real", "Integer"):
            return self._f[f"fmi1Get{typ}"](self.c, port.vr_ptr, port.n, port.buf_ptr)
        st = self._f[f"fmi1Get{typ}"](self.c, port.vr_ptr, port.n, port.extra)
        if typ == "Boolean":
            port.buf[:] = np.frombuffer(port.extra, dtype=np.int8) != 0
        else:
            port.buf[:] = [v.decode("utf-8", "replace") if v is not None else "" for v in port.extra]
        return st

    def set_port(self, typ, port) -> int:
        if typ in ("Real", "Integer"):
            return self._f[f"fmi1Set{typ}"](self.c, port.vr_ptr, port.n, port.buf_ptr)
        if typ == "Boolean":
            np.frombuffer(port.extra, dtype=np.int8)[:] = port.buf != 0
        else:
            port.extra[:] = [str(v).encode() for v in port.buf]
        return self._f[f"fmi1Set{typ}"](self.c, port.vr_ptr, port.n, port.extra)

    # -- stepping -----------------------------------------------------------------------------------------
    def do_step(self, t, h) -> int:
        return self._f["fmi1DoStep"](self.c, t, h, 1)      # newStep: every call starts a new step

    def bound_get(self, typ, port):
        """Real and Integer after initialization: the raw C function with ready arguments (as FMI 2.0)."""
        if typ not in ("Real", "Integer"):
            return super().bound_get(typ, port)
        return functools.partial(self.lib.raw(f"fmi1Get{typ}"), c_void_p(self.c), port.vr_ptr, c_size_t(port.n),
                                 port.buf_ptr)

    def bound_set(self, typ, port):
        if typ not in ("Real", "Integer"):
            return super().bound_set(typ, port)
        return functools.partial(self.lib.raw(f"fmi1Set{typ}"), c_void_p(self.c), port.vr_ptr, c_size_t(port.n),
                                 port.buf_ptr)

    def bound_step(self):
        do_step, c = self._f["fmi1DoStep"], c_void_p(self.c)

        def step(t, h):
            return do_step(c, t, h, 1)
        return step
