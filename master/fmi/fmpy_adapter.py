"""The one place that reaches into fmpy: loading an FMU's shared library, its raw function table, the
callback structures, and the CVode solver. fmpy keeps these behind private attributes (``_functions``,
``_loadFunctions``, ``dll._handle``), so a change of fmpy breaks this module only."""
from __future__ import annotations

import ctypes
import functools
import inspect
import os
import types
import typing

from ..errors import FmuError

# Other names under which exporters publish an FMI function: tools that predate the final FMI 2.0 names
# (JModelica.org 1.15) or capitalise them their own way spell the FMU state functions differently. Looked up
# only when the standard name is missing.
ALIASES = {
    "fmi2GetFMUstate": ("fmi2GetFMUState",),
    "fmi2SetFMUstate": ("fmi2SetFMUState",),
    "fmi2FreeFMUstate": ("fmi2FreeFMUState",),
    "fmi2SerializedFMUstateSize": ("fmi2SerializedFMUStateSize",),
    "fmi2SerializeFMUstate": ("fmi2SerializeFMUState",),
    "fmi2DeSerializeFMUstate": ("fmi2DeserializeFMUstate", "fmi2DeserializeFMUState", "fmi2DeSerializeFMUState"),
}


class MissingFunction(KeyError):
    """The FMU's library exports neither the function nor a known alias of it."""

    def __str__(self):
        return f"the FMU's binary does not export {self.args[0]}"


def _symbol(dll, name: str):
    """The library's function for ``name`` or a known alias of it (MissingFunction when it has neither)."""
    for candidate in (name, *ALIASES.get(name, ())):
        try:
            return getattr(dll, candidate)
        except AttributeError:
            continue
    raise MissingFunction(name)


def _prototype(c_fun, method) -> None:
    """Argument and result types from fmpy's annotated Python method of the same name (what fmpy's own
    ``_loadFunctions`` does, for one function). fmpy annotates several FMI 1.0 co-simulation functions
    (fmiInitializeSlave, fmiDoStep, fmiGet*Status ...) as returning fmi1String although they return an
    fmiStatus; the genuine string results (fmiGetVersion, fmiGetTypesPlatform) are annotated ``bytes``."""
    sig = inspect.signature(method)
    argtypes = []
    for param in sig.parameters.values():
        annotation = param.annotation
        if isinstance(annotation, types.UnionType):
            annotation = typing.get_args(annotation)[0]
        argtypes.append(annotation)
    restype = sig.return_annotation
    if restype is ctypes.c_char_p and method.__name__.startswith("fmi1"):
        restype = ctypes.c_int
    restype = ctypes.c_char_p if restype is bytes else ctypes.c_int if restype is int else restype
    c_fun.argnames = list(sig.parameters)
    c_fun.argtypes = argtypes
    c_fun.restype = restype


class _LazyFunctions(dict):
    """fmpy's function table, filled on first use. fmpy looks up every FMI function when it loads a library
    and refuses an FMU that lacks an optional one or exports it under an older name; here a function is
    looked up (with its aliases) only when it is called, and a missing one is a MissingFunction then."""

    def __init__(self, fmu):
        super().__init__()
        self._fmu = fmu

    def __missing__(self, name: str):
        method = getattr(self._fmu, name, None)
        if method is None:                  # not a function of this FMI kind (fmi2DoStep for model exchange)
            raise MissingFunction(name)
        c_fun = _symbol(self._fmu.dll, exported_name(self._fmu, name))
        _prototype(c_fun, method)
        self[name] = c_fun
        return c_fun


def exported_name(fmu, name: str) -> str:
    """The symbol the library exports for fmpy's function ``name``: FMI 1.0 binaries prefix every function with
    their model identifier ("fmi1DoStep" -> "Gain_fmiDoStep"), so that several can be linked into one program."""
    if name.startswith("fmi1"):
        return f"{fmu.modelIdentifier}_fmi{name[4:]}"
    return name


@functools.cache
def _lazy(cls):
    """fmpy's FMU class with the function table filled on demand instead of all at once."""
    class Lazy(cls):
        def _loadFunctions(self):
            self._functions = _LazyFunctions(self)
    return Lazy


class Library:
    """An FMU's shared library as fmpy loaded it (``obj`` is fmpy's FMU object, for its public methods)."""

    def __init__(self, obj):
        self.obj = obj
        self.functions = obj._functions
        self._pydll = None

    def __getitem__(self, name: str):
        return self.functions[name]

    def get(self, name: str):
        """The function, or None when the FMU does not export it (optional functions)."""
        try:
            return self.functions[name]
        except MissingFunction:
            return None

    def bind_instance(self, component) -> None:
        """fmpy's own methods (used for model exchange) act on this instance."""
        self.obj.component = component

    def raw(self, name: str):
        """A fresh function object without argtypes: called with ready ctypes arguments it skips the
        per-argument conversion that fmpy's prototypes perform on every call. It comes from a PyDLL view of
        the same library handle, so the GIL is kept across the call instead of being released and re-acquired
        three times per FMU step (the master is single-threaded; a pythonfmu binary re-entering Python from
        this thread finds the GIL already held, which PyGILState_Ensure allows)."""
        if self._pydll is None:
            self._pydll = ctypes.PyDLL(self.obj.dll._name, handle=self.obj.dll._handle)
        return _symbol(self._pydll, exported_name(self.obj, name))


def load_library(kind: str, name: str, fmu, shown_as: str, model_identifier: str) -> Library:
    """Load the FMU's binary for ``kind`` ("fmi1cs", "fmi2cs", "fmi2me", "fmi3cs", "fmi3me"). fmpy changes the
    working directory while loading and does not change it back when the library fails to load, so the caller's
    directory is restored here."""
    if kind == "fmi1cs":
        from fmpy.fmi1 import FMU1Slave as cls
    elif kind == "fmi2cs":
        from fmpy.fmi2 import FMU2Slave as cls
    elif kind == "fmi2me":
        from fmpy.fmi2 import FMU2Model as cls
    elif kind == "fmi3cs":
        from fmpy.fmi3 import FMU3Slave as cls
    elif kind == "fmi3me":
        from fmpy.fmi3 import FMU3Model as cls
    else:   # pragma: no cover - the factory names the kinds
        raise ValueError(kind)
    cwd = os.getcwd()
    try:
        return Library(_lazy(cls)(guid=fmu.md.guid, unzipDirectory=str(fmu.unzip_dir),
                                  modelIdentifier=model_identifier, instanceName=name))
    except Exception as exc:
        missing = _missing_platform(fmu)
        reason = missing or f"cannot load the FMU's binary: {' '.join(str(exc).split())}"
        raise FmuError(reason, file=shown_as, element=f"component {name}") from None
    finally:
        os.chdir(cwd)


def _missing_platform(fmu) -> str | None:
    """'this FMU has binaries for win32, win64 only' when it has none for this platform (a clearer reason than
    the missing shared library)."""
    from fmpy import platform as fmpy_platform, platform_tuple
    here = platform_tuple if fmu.fmi_version.startswith("3") else fmpy_platform
    folder = fmu.unzip_dir / "binaries"
    found = sorted(p.name for p in folder.iterdir() if p.is_dir()) if folder.is_dir() else []
    if here in found:
        return None
    return (f"this FMU has binaries for {', '.join(found)} only, not for {here}" if found
            else f"this FMU has no binaries (source code only?), not for {here}")


def fmi2_callbacks(logger):
    """fmi2CallbackFunctions with our logger. fmpy's native logger proxy (which would expand printf-style
    arguments) keeps a single global target, so messages of several instances would all reach the last one;
    messages are taken verbatim instead."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


def fmi1_callbacks(logger):
    """fmiCallbackFunctions (FMI 1.0, passed by value) with our logger, messages taken verbatim as for FMI 2.0;
    no stepFinished: doStep is called synchronously."""
    from fmpy import calloc, free
    from fmpy.fmi1 import (fmi1CallbackAllocateMemoryTYPE, fmi1CallbackFreeMemoryTYPE, fmi1CallbackFunctions,
                           fmi1CallbackLoggerTYPE)
    cb = fmi1CallbackFunctions()
    cb.logger = fmi1CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi1CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi1CallbackFreeMemoryTYPE(free)
    cb.stepFinished = None
    return cb


def fmi3_callbacks(logger):
    """(log message callback, intermediate update callback) for fmi3Instantiate*."""
    from fmpy.fmi3 import fmi3IntermediateUpdateCallback, fmi3LogMessageCallback
    return (fmi3LogMessageCallback(lambda env, status, cat, msg: logger(env, None, status, cat, msg)),
            fmi3IntermediateUpdateCallback())


CVODE_METHODS = ("bdf", "adams")


@functools.cache
def _cvode_class(method: str):
    """fmpy's CVodeSolver for a linear multistep method. fmpy creates its solver with CVodeCreate(CV_BDF) and
    offers no choice; for Adams its ``__init__`` is re-bound to globals in which CVodeCreate makes an Adams
    solver instead (everything else as fmpy does it: tolerances, root finding, dense Newton iteration)."""
    from fmpy.sundials import CVodeSolver
    if method == "bdf":
        return CVodeSolver
    if method != "adams":
        raise ValueError(method)
    from fmpy.sundials.cvode import CV_ADAMS, CVodeCreate
    init = CVodeSolver.__init__

    def create_adams(_lmm, context):
        return CVodeCreate(CV_ADAMS, context)
    adams_init = types.FunctionType(init.__code__, {**init.__globals__, "CVodeCreate": create_adams},
                                    init.__name__, init.__defaults__, init.__closure__)
    return type("AdamsCVodeSolver", (CVodeSolver,), {"__init__": adams_init})


def _cvode_counter(name: str):
    """A CVodeGetNum* function of fmpy's SUNDIALS library (fmpy binds the solver calls only, not these)."""
    from fmpy.sundials.libraries import sundials_cvode
    fn = getattr(sundials_cvode, name)
    fn.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_long)]
    fn.restype = ctypes.c_int
    return fn


# run.json name -> CVode counter
_CVODE_COUNTERS = {"steps": "CVodeGetNumSteps", "rhs_evaluations": "CVodeGetNumRhsEvals",
                   "root_function_evaluations": "CVodeGetNumGEvals", "error_test_failures": "CVodeGetNumErrTestFails"}


class CVode:
    """fmpy's CVode over a model-exchange instance, with counters for the whole run: CVodeReInit (at every
    communication step and after every event) sets CVode's own counters to zero, so they are banked first."""

    def __init__(self, calls, nx: int, nz: int, start: float, rtol: float, method: str = "bdf"):
        class _NoInput:                      # inputs are held by the caller over a communication step
            @staticmethod
            def apply(t):
                return None
        self.method = method
        self._solver = _cvode_class(method)(
            nx=nx, nz=nz, get_x=calls.get_x, set_x=calls.set_x, get_dx=calls.get_dx, get_z=calls.get_z,
            get_nominals=calls.get_nominals, set_time=calls.set_time, input=_NoInput, startTime=start,
            relativeTolerance=rtol)
        self._counters = {key: _cvode_counter(name) for key, name in _CVODE_COUNTERS.items()}
        self._banked = dict.fromkeys(self._counters, 0)

    def step(self, t: float, t_next: float):
        """(state event found, roots, time reached) as fmpy's CVodeSolver.step."""
        return self._solver.step(t, t_next)

    def reset(self, t: float) -> None:
        for key, value in self._since_reset().items():
            self._banked[key] += value
        self._solver.reset(t)

    def _since_reset(self) -> dict:
        out = {}
        for key, fn in self._counters.items():
            value = ctypes.c_long(0)
            fn(self._solver.cvode_mem, ctypes.byref(value))
            out[key] = value.value
        return out

    def stats(self) -> dict:
        return {key: self._banked[key] + value for key, value in self._since_reset().items()}
