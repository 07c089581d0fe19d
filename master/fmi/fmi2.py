"""FMI 2.0 co-simulation instances: fmpy loads the library, the hot path calls the C functions directly."""
from __future__ import annotations

import ctypes
import functools
from ctypes import byref, c_char_p, c_double, c_int, c_uint, c_void_p

from .fmpy_adapter import fmi2_callbacks, load_library
from .native import NativeSlave
from .slave import DISCARD, ERROR, WARNING, Port

FMI2_TERMINATED = 3        # fmi2StatusKind fmi2Terminated: does the slave want to end the simulation?


class Fmi2Slave(NativeSlave):
    """FMI 2.0 co-simulation through fmpy's library loading, with direct ctypes calls on the hot path."""
    GET_STATE, SET_STATE, FREE_STATE = "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate"
    TERMINATE, FREE_INSTANCE = "fmi2Terminate", "fmi2FreeInstance"


    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        self.lib = load_library(self._library_kind, name, fmu, shown_as, self._model_identifier(fmu))
        self.logging_on = logging_on
        self._f = self.lib
        self.c = None
        self.can_save_state = bool(getattr(self._fmi_kind(fmu), "canGetAndSetFMUstate", False))
        self.can_interpolate_inputs = bool(getattr(self._fmi_kind(fmu), "canInterpolateInputs", False))
        self.max_output_derivative_order = int(getattr(self._fmi_kind(fmu), "maxOutputDerivativeOrder", 0) or 0)

    _library_kind = "fmi2cs"

    @staticmethod
    def _fmi_kind(fmu):
        return fmu.md.coSimulation

    def _model_identifier(self, fmu):
        return self._fmi_kind(fmu).modelIdentifier

    def instantiate(self):
        cb = self._callbacks = fmi2_callbacks(self._logger_fn())
        uri = (self.fmu.unzip_dir / "resources").as_uri()
        comp = self._f["fmi2Instantiate"](self.name.encode(), self._instantiate_call(), self.fmu.md.guid.encode(),
                                          uri.encode(),
                                          byref(cb), 0, 1 if self.logging_on else 0)
        if not comp:
            raise self.fail("fmi2Instantiate", ERROR)
        self.c = comp
        self.lib.bind_instance(comp)
        self.instantiated = True
        f = self._f
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

    def input_derivatives_setter(self, vrs, orders):
        n = len(vrs)
        f, c = self._f["fmi2SetRealInputDerivatives"], c_void_p(self.c)
        vr_arr, order_arr, values = (c_uint * n)(*vrs), (c_int * n)(*orders), (c_double * n)()

        def put(v) -> int:
            values[:] = [float(x) for x in v]
            return f(c, vr_arr, n, order_arr, values)
        return put

    def output_derivatives_getter(self, vrs, orders):
        n = len(vrs)
        f, c = self._f["fmi2GetRealOutputDerivatives"], c_void_p(self.c)
        vr_arr, order_arr, values = (c_uint * n)(*vrs), (c_int * n)(*orders), (c_double * n)()

        def get():
            return f(c, vr_arr, n, order_arr, values), list(values)
        return get

    def asks_to_terminate(self, status: int) -> bool:
        """After a doStep returned ``status`` above Warning: whether the slave asks to end the simulation
        (Discard with fmi2Terminated) instead of failing."""
        if status != DISCARD:
            return False
        terminated = c_int()
        get = self._f.get("fmi2GetBooleanStatus")
        return get is not None and get(self.c, FMI2_TERMINATED, byref(terminated)) <= WARNING and bool(terminated.value)

    def bound_get(self, typ, port):
        if typ == "String":
            return super().bound_get(typ, port)
        return functools.partial(self.raw_function(f"fmi2Get{typ}"), c_void_p(self.c), port.vr_ptr, ctypes.c_size_t(port.n),
                                 port.buf_ptr)

    def bound_set(self, typ, port):
        if typ == "String":
            return super().bound_set(typ, port)
        return functools.partial(self.raw_function(f"fmi2Set{typ}"), c_void_p(self.c), port.vr_ptr, ctypes.c_size_t(port.n),
                                 port.buf_ptr)

    def bound_step(self):
        f, c = self._do_step, c_void_p(self.c)

        def step(t, h):
            return f(c, t, h, 1)
        return step

    @property
    def raw_step(self):
        return functools.partial(self.raw_function("fmi2DoStep"), c_void_p(self.c)) if self._do_step is not None else None
