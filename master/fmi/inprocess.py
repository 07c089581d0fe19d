"""pythonfmu FMUs run in process: the master loads the FMU's own slave class from its resources and calls
it directly, which is what the FMU's binary does through an extra foreign-call layer (C++ wrapper, GIL
hand-over, list building per call).

The calls mirror pythonfmu's wrapper so that results are bit-identical to the binary path: the resources
folder goes first on sys.path, the module named in resources/slavemodule.txt is imported, its Fmi2Slave
subclass is constructed with instance_name/resources/visible, setup_experiment receives (start, stop or None,
tolerance or None), do_step returning False is reported as Discard, an exception as Fatal (the wrapper turns
Python exceptions into a fatal error) with the exception's text,
and log messages queued by the slave are forwarded after every call.

Three modules: ``inprocess_import.py`` imports the slave module (in isolation where it clashes with what is
imported), this one is the slave's life cycle, ``inprocess_ops.py`` its fast-path operations.
"""
from __future__ import annotations

import sys
import traceback
from pathlib import Path

from ..errors import FmuError
from .inprocess_import import (_resources_folder, _slave_class, _slave_module_text, is_pythonfmu,  # noqa: F401
                               load_slave_module)
from .inprocess_ops import _CONVERT, InlineCycle, InlineGet, InProcessOps, _shell_bind  # noqa: F401 (importable here)
from .logsink import STATUS_LEVEL
from .slave import DISCARD, ERROR, FATAL, OK, Port, Slave


class PythonFmuSlave(InProcessOps, Slave):
    kind = "CoSimulation (in process)"
    bound_get_in_init = True     # the same get_<type> values in any mode (a raising fetch retries through get_port)

    def __init__(self, name, fmu, log, shown_as):
        super().__init__(name, fmu, log, shown_as)
        self.resources = _resources_folder(fmu.unzip_dir)
        text = _slave_module_text(fmu.unzip_dir)
        if text is None:        # gone since is_pythonfmu looked: read it to raise what reading it raised
            text = Path(self.resources, "slavemodule.txt").read_text()
        module_name = text.splitlines()[0].strip()
        try:
            module, clashes = load_slave_module(self.resources, module_name)
        except Exception as exc:
            raise FmuError(f"cannot import the FMU's Python module {module_name!r}: {exc}", file=shown_as,
                           element=f"component {name}") from None
        if clashes:
            what = f"{clashes[0]} differs" if len(clashes) == 1 else f"{', '.join(clashes)} differ"
            log.message(name, "info", f"loaded in isolation: {what} from the imported copy")
        cls = _slave_class(module, fmu.md.coSimulation.modelIdentifier)
        if cls is None:
            raise FmuError(f"no Fmi2Slave class found in {module_name}.py", file=shown_as, element=f"component {name}")
        self.cls = cls
        self.obj = None
        self.can_save_state = bool(getattr(fmu.md.coSimulation, "canGetAndSetFMUstate", False))

    # -- calls, each followed by forwarding the slave's log queue --------------------------------------------
    def _drain(self):
        q = self.obj.log_queue
        if q:
            for m in q:
                status = int(getattr(m, "status", 0))
                self.log.message(self.name, STATUS_LEVEL.get(status, "info"), str(getattr(m, "msg", m)))
            q.clear()

    def _call(self, what, fn, *args):
        try:
            result = fn(*args)
        except Exception as exc:
            self.log.message(self.name, "error", f"{what}: {type(exc).__name__}: {exc}")
            self.log.message(self.name, "debug", traceback.format_exc())
            return FATAL, None
        if self.obj is not None and self.obj.log_queue:
            self._drain()
        return OK, result

    def instantiate(self):
        st, obj = self._construct()
        if st != OK:
            raise self.fail("instantiate (in process)", st)
        self.obj = obj
        self.instantiated = True

    def _construct(self):
        try:
            return OK, self.cls(instance_name=self.name, resources=self.resources, visible=False)
        except Exception as exc:
            self.log.message(self.name, "error", f"constructor: {type(exc).__name__}: {exc}")
            return ERROR, None

    def setup(self, start, stop, tolerance=None):
        st, _ = self._call("setup_experiment", self.obj.setup_experiment, start, stop, tolerance)
        self.check("setup_experiment", st, start)

    def enter_init(self, t):
        st, _ = self._call("enter_initialization_mode", self.obj.enter_initialization_mode)
        self.check("enter_initialization_mode", st, t)

    def exit_init(self, t):
        st, _ = self._call("exit_initialization_mode", self.obj.exit_initialization_mode)
        self.check("exit_initialization_mode", st, t)
        self.initialized = True

    def set_value(self, typ, vr, value):
        fn = getattr(self.obj, f"set_{typ.lower()}")
        st, _ = self._call(f"set_{typ.lower()}", fn, [vr], [_CONVERT[typ](value)])
        return st

    def values_setter(self, typ, vrs):
        """One update of the instance's __dict__ when the shell binds plain attributes for them (``set_raw``, see
        bound_set): set_<type>([vr], [value]) one by one stores the same converted values under the same names in
        the same order, and such stores run no code of the FMU (nothing to log, nothing to fail)."""
        raw = _shell_bind(self.obj, "set_raw", typ, vrs) if typ in _CONVERT else None
        if raw is None:
            return None
        update, names = raw
        conv = _CONVERT[typ]

        def put(values) -> bool:
            try:
                update(zip(names, [conv(v) for v in values]))
            except Exception:       # noqa: BLE001 - one by one, which sets them all again or fails as before
                return False
            return True
        return put

    def make_port(self, typ, vrs, buf):
        port = Port(vrs, buf, None, native=False)
        port.extra = [int(v) for v in port.vrs]
        return port

    def get_port(self, typ, port) -> int:
        st, values = self._call(f"get_{typ.lower()}", getattr(self.obj, f"get_{typ.lower()}"), port.extra)
        if st == OK:
            port.buf[:] = values
        return st

    def set_port(self, typ, port) -> int:
        conv = _CONVERT[typ]
        # tolist(): the buffer's values as Python numbers (numpy's scalars, which iterating gives, convert to the
        # same ones, one call each)
        st, _ = self._call(f"set_{typ.lower()}", getattr(self.obj, f"set_{typ.lower()}"), port.extra,
                           [conv(v) for v in port.buf.tolist()])
        return st

    def do_step(self, t, h) -> int:
        st, ok = self._call("do_step", self.obj.do_step, t, h)
        if st != OK:
            return st
        return OK if ok else DISCARD

    def asks_to_terminate(self, status: int) -> bool:
        """A do_step that returned False is a Discard, which pythonfmu's binary reports together with
        fmi2Terminated: the slave asks to end the simulation (the same here as through the binary)."""
        return status == DISCARD

    def _step_error(self, t, h):
        exc = sys.exc_info()[1]
        self.log.message(self.name, "error", f"do_step: {type(exc).__name__}: {exc}")
        if self.obj.log_queue:
            self._drain()
        return FATAL

    def save_state(self, t=None):
        if not self.can_save_state:
            return super().save_state(t)
        st, state = self._call("get_fmu_state", self.obj._get_fmu_state)
        self.check("get_fmu_state", st, t)
        return state

    def restore_state(self, token, t=None):
        if not self.can_save_state:
            return super().restore_state(token, t)
        st, _ = self._call("set_fmu_state", self.obj._set_fmu_state, token)
        self.check("set_fmu_state", st, t)

    def terminate(self):
        if self.initialized:
            self.initialized = False
            st, _ = self._call("terminate", self.obj.terminate)
            return st
        return OK

    def free(self):
        if self.instantiated:
            self.instantiated = False
            self.obj = None
