"""The one place that reaches into fmpy: loading an FMU's shared library, its raw function table, the
callback structures, and the CVode solver. fmpy keeps these behind private attributes (``_functions``,
``dll._handle``), so a change of fmpy breaks this module only."""
from __future__ import annotations

import ctypes
import os

from ..errors import FmuError


class Library:
    """An FMU's shared library as fmpy loaded it (``obj`` is fmpy's FMU object, for its public methods)."""

    def __init__(self, obj):
        self.obj = obj
        self.functions = obj._functions
        self._pydll = None

    def __getitem__(self, name: str):
        return self.functions[name]

    def get(self, name: str):
        return self.functions.get(name)

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
        return self._pydll[name]


def load_library(kind: str, name: str, fmu, shown_as: str, model_identifier: str) -> Library:
    """Load the FMU's binary for ``kind`` ("fmi2cs", "fmi2me", "fmi3cs"). fmpy changes the working directory
    while loading and does not change it back when the library fails to load, so the caller's directory is
    restored here."""
    if kind == "fmi2cs":
        from fmpy.fmi2 import FMU2Slave as cls
    elif kind == "fmi2me":
        from fmpy.fmi2 import FMU2Model as cls
    elif kind == "fmi3cs":
        from fmpy.fmi3 import FMU3Slave as cls
    else:   # pragma: no cover - the factory names the kinds
        raise ValueError(kind)
    cwd = os.getcwd()
    try:
        return Library(cls(guid=fmu.md.guid, unzipDirectory=str(fmu.unzip_dir), modelIdentifier=model_identifier,
                           instanceName=name))
    except Exception as exc:
        raise FmuError(f"cannot load the FMU's binary: {' '.join(str(exc).split())}", file=shown_as,
                       element=f"component {name}") from None
    finally:
        os.chdir(cwd)


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


def fmi3_callbacks(logger):
    """(log message callback, intermediate update callback) for fmi3Instantiate*."""
    from fmpy.fmi3 import fmi3IntermediateUpdateCallback, fmi3LogMessageCallback
    return (fmi3LogMessageCallback(lambda env, status, cat, msg: logger(env, None, status, cat, msg)),
            fmi3IntermediateUpdateCallback())


def cvode_solver(model, nx: int, nz: int, start: float, rtol: float):
    """fmpy's CVode wrapper over an FMI 2.0 model-exchange instance (inputs are held by the caller)."""
    from fmpy.sundials import CVodeSolver

    class _NoInput:
        @staticmethod
        def apply(t):
            return None
    m = model
    return CVodeSolver(nx=nx, nz=nz, get_x=m.getContinuousStates, set_x=m.setContinuousStates,
                       get_dx=m.getDerivatives, get_z=m.getEventIndicators,
                       get_nominals=m.getNominalsOfContinuousStates, set_time=m.setTime,
                       input=_NoInput, startTime=start, relativeTolerance=rtol)
