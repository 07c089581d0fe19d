"""pythonfmu FMUs run in process: the master loads the FMU's own slave class from its resources and calls
it directly, which is what the FMU's binary does through an extra foreign-call layer (C++ wrapper, GIL
hand-over, list building per call).

The calls mirror pythonfmu's wrapper so that results are bit-identical to the binary path: the resources
folder goes first on sys.path, the module named in resources/slavemodule.txt is imported, its Fmi2Slave
subclass is constructed with instance_name/resources/visible, setup_experiment receives (start, stop or None,
tolerance or None), do_step returning False is reported as Discard, an exception as Fatal (the wrapper turns
Python exceptions into a fatal error) with the exception's text,
and log messages queued by the slave are forwarded after every call.

The binary runs each FMU in its own interpreter state, so an FMU always runs the code it bundles. In one process,
a top-level name the FMU's resources provide (``uavsim``, its slave module) may already be imported from elsewhere
(the installed package, or another FMU's copy). When every such name is unimported or imported from
byte-identical .py files, the FMU is imported as usual (shared modules, no cost); otherwise it is loaded in
isolation (:class:`_Isolated`): its own copies of all the names its resources provide, kept apart from
sys.modules.
"""
from __future__ import annotations

import builtins
import functools
import hashlib
import importlib
import importlib.machinery
import importlib.util
import operator
import struct
import sys
import threading
import traceback
from functools import lru_cache
from pathlib import Path
from typing import Callable, NamedTuple

from ..errors import FmuError
from .logsink import STATUS_LEVEL
from .slave import DISCARD, ERROR, FATAL, OK, SET_FAILED, WARNING, Port, Slave

_CONVERT = {"Real": float, "Integer": int, "Boolean": bool, "String": str}


class InlineCycle(NamedTuple):
    """What a cycle op (``bound_cycle``) does, for a compiled step that writes the same calls into its own code
    (no Python frame per component): ``sets`` (update, names, tolist) each called as update(zip(names,
    tolist())); after one raised, ``sets_failed()`` sets the ports again through the reporting path and gives the
    failing port's status (0: they all went through); ``do_step(t, h)`` true is OK, false Discard; after it
    raised, ``step_error(t, h)`` logs and gives the status; ``obj.log_queue`` is drained by ``drain()``."""
    sets: tuple
    sets_failed: Callable
    do_step: Callable
    step_error: Callable
    obj: object
    drain: Callable


class InlineGet(NamedTuple):
    """What a getter op (``bound_get`` of a slave with ``get_raw``) does, for the compiled step: ``kind``
    "single" is buf[0] = fetch(arg), "pack" pack_into(buf, 0, *fetch(arg)), "assign" buf[:] = fetch(arg); after
    it raised, ``retry()`` reads through the reporting path and gives the status."""
    kind: str
    fetch: Callable
    arg: object
    names: tuple | None         # when ``arg`` is the instance's __dict__: the keys ``fetch`` reads, in order
    buf: object
    pack_into: Callable | None
    retry: Callable
    obj: object
    drain: Callable


_resources: dict[str, str] = {}      # unpacked FMU folder -> its resources folder, as the slave module is keyed


def _resources_folder(unzip_dir) -> str:
    key = str(unzip_dir)
    folder = _resources.get(key)
    if folder is None:
        folder = _resources[key] = str(Path(key, "resources"))
    return folder


def is_pythonfmu(fmu) -> bool:
    return (fmu.md.coSimulation is not None and _slave_module_text(fmu.unzip_dir) is not None
            and (fmu.md.generationTool or "").lower().startswith("pythonfmu"))


_module_texts: dict[str, str | None] = {}      # unpacked FMU folder -> its resources/slavemodule.txt or None


def _slave_module_text(unzip_dir) -> str | None:
    """The text of the FMU's resources/slavemodule.txt (None: it has none), read once per unpacked folder: a
    folder is named by its archive's SHA-256 (fmi/cache.py), so what it holds does not change, and every
    component of every run made the same path look-ups and read again."""
    key = str(unzip_dir)
    if key not in _module_texts:
        path = Path(key, "resources", "slavemodule.txt")
        _module_texts[key] = path.read_text() if path.is_file() else None
    return _module_texts[key]


_classes: dict[tuple, type | None] = {}      # (slave module, model identifier) -> its slave class


def _slave_class(module, model_identifier):
    """The module's Fmi2Slave class of that name (or its only one), looked up once per module: a module is imported
    once per resources folder (``load_slave_module``), and every component of every run scanned its names again."""
    key = (module, model_identifier)
    if key not in _classes:
        _classes[key] = _find_slave_class(module, model_identifier)
    return _classes[key]


def _find_slave_class(module, model_identifier):
    from pythonfmu import Fmi2Slave
    candidates = [obj for obj in vars(module).values()
                  if isinstance(obj, type) and issubclass(obj, Fmi2Slave) and obj is not Fmi2Slave
                  and obj.__module__ == module.__name__]
    for c in candidates:
        if c.__name__ == model_identifier:
            return c
    return candidates[0] if len(candidates) == 1 else None


# -- the FMU's own code, also where its module names are taken -------------------------------------------------
def _provided(resources: Path) -> list[str]:
    """The top-level modules and packages a resources folder provides; pythonfmu always comes from the installed
    package (as in pythonfmu's own binary, which imports it before the slave module)."""
    names = {p.stem for p in resources.glob("*.py")}
    names |= {p.name for p in resources.iterdir() if (p / "__init__.py").is_file()}
    return sorted(names - {"pythonfmu"})


@lru_cache(maxsize=None)
def _digest(path: str) -> str | None:
    """A module's source identity: the SHA-256 of its .py file, or of a package's .py files with their relative
    paths (compiled parts are built from these)."""
    p = Path(path)
    if p.is_file():
        return "file " + hashlib.sha256(p.read_bytes()).hexdigest() if p.suffix == ".py" else None
    if not p.is_dir():
        return None
    h = hashlib.sha256(b"package")
    for f in sorted(p.rglob("*.py")):
        if "__pycache__" not in f.parts:
            h.update(f.relative_to(p).as_posix().encode() + b"\0" + hashlib.sha256(f.read_bytes()).digest())
    return h.hexdigest()


def _source(module) -> str | None:
    file = getattr(module, "__file__", None)
    if not file:
        return None
    return str(Path(file).parent) if hasattr(module, "__path__") else file


def _clashes(resources: Path, names) -> list[str]:
    """The provided names already imported from other code than the bundled one."""
    out = []
    for n in names:
        loaded = sys.modules.get(n)
        if loaded is None:
            continue
        bundled = resources / n if (resources / n).is_dir() else resources / f"{n}.py"
        src = _source(loaded)
        if src is None or _digest(src) != _digest(str(bundled)):
            out.append(n)
    return out


_real_import = builtins.__import__
_SECTION = threading.RLock()       # one isolated import at a time: it swaps entries of the global sys.modules


class _Isolated:
    """One FMU's private copies of the top-level names its resources provide.

    They are imported with the FMU's modules swapped into sys.modules and its resources first on sys.path, and
    moved out again afterwards. An import statement that runs later, inside a function (``import uavsim.x``,
    ``from . import x``), would look in the global sys.modules; so every module of the FMU gets its own
    ``__builtins__`` whose ``__import__`` answers the FMU's names from its copies (and imports a missing one the
    same isolated way). This costs nothing per call into the slave and holds across threads, unlike swapping
    sys.modules around every call. Not covered: ``importlib.import_module`` of an FMU name inside the FMU's code.
    """

    def __init__(self, resources: str, names):
        self.resources = resources
        self.names = frozenset(names)
        self.modules: dict = {}
        self.builtins = dict(vars(builtins), __import__=self._import)
        self._owner = None

    def owns(self, name: str) -> bool:
        return name.partition(".")[0] in self.names

    # a meta-path finder active during the section: the FMU's names come from its resources only, and their
    # source modules run with the FMU's builtins
    def find_spec(self, name, path=None, target=None):
        if not self.owns(name):
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path if path is not None else [self.resources])
        if spec is not None and type(spec.loader) is importlib.machinery.SourceFileLoader:
            spec.loader = _FmuSourceLoader(spec.loader.name, spec.loader.path, self.builtins)
        return spec

    def section(self, fn):
        with _SECTION:
            outer, self._owner = self._owner, threading.get_ident()
            saved = {k: m for k, m in sys.modules.items() if self.owns(k)}
            for k in saved:
                del sys.modules[k]
            sys.modules.update(self.modules)
            path = sys.path[:]
            sys.path.insert(0, self.resources)
            sys.meta_path.insert(0, self)
            try:
                return fn()
            finally:
                sys.meta_path.remove(self)
                sys.path[:] = path
                for k in [k for k in sys.modules if self.owns(k)]:
                    self.modules[k] = sys.modules.pop(k)
                sys.modules.update(saved)
                self._owner = outer

    def _import(self, name, globals=None, locals=None, fromlist=(), level=0):
        full = name
        if level:
            package = (globals or {}).get("__package__") or ""
            full = importlib.util.resolve_name("." * level + name, package)
        if not self.owns(full) or self._owner == threading.get_ident():
            return _real_import(name, globals, locals, fromlist, level)
        mod = self.modules.get(full)
        if mod is not None and all(f == "*" or hasattr(mod, f) for f in fromlist or ()):
            if fromlist:
                return mod
            if not level:
                return self.modules[full.partition(".")[0]]
        return self.section(lambda: _real_import(name, globals, locals, fromlist, level))


class _FmuSourceLoader(importlib.machinery.SourceFileLoader):
    def __init__(self, fullname, path, fmu_builtins):
        super().__init__(fullname, path)
        self.fmu_builtins = fmu_builtins

    def exec_module(self, module):
        module.__dict__["__builtins__"] = self.fmu_builtins     # exec keeps a __builtins__ already there
        super().exec_module(module)


_by_folder: dict[str, tuple] = {}      # resources folder -> (slave module, names loaded in isolation)


def load_slave_module(resources: str, module_name: str):
    """The FMU's slave module, imported once per resources folder (unpacked folders are keyed by the archive's
    hash, so the same FMU shares it); the second item lists the names that clashed (empty: imported as usual)."""
    if resources in _by_folder:
        return _by_folder[resources]
    import pythonfmu  # noqa: F401  (the installed package, before any bundled copy could shadow it)
    names = _provided(Path(resources))
    clashes = _clashes(Path(resources), names)
    if not clashes:
        if resources not in sys.path:
            sys.path.insert(0, resources)
        module = importlib.import_module(module_name)
    else:
        iso = _Isolated(resources, names)
        iso.section(lambda: importlib.import_module(module_name))
        module = iso.modules[module_name]
    _by_folder[resources] = (module, clashes)
    return module, clashes


def _shell_bind(obj, op, typ, vrs):
    """``obj.cosim_bind(op, typ, vrs)`` (see ``PythonFmuSlave._bound``), or None."""
    bind = getattr(obj, "cosim_bind", None)
    if bind is None:
        return None
    try:
        return bind(op, typ, list(vrs))
    except Exception:       # noqa: BLE001 - an optional shortcut: the FMI functions remain
        return None


class PythonFmuSlave(Slave):
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

    # -- fast-path operations: bound once, called every step ------------------------------------------------
    # The binary calls the slave's get_<type>/set_<type> methods; so do these operations. Where the class keeps
    # pythonfmu's own implementation (which type-checks each variable and calls its getter or setter), the
    # variables are checked once here and their getters/setters called directly, which is the same work.
    def _direct(self, op, typ, vrs):
        from pythonfmu import Fmi2Slave
        from pythonfmu import variables as pv
        name = f"{op}_{typ.lower()}"
        if getattr(type(self.obj), name) is not getattr(Fmi2Slave, name):
            return None
        kind = {"Real": pv.Real, "Integer": pv.Integer, "Boolean": pv.Boolean, "String": pv.String}[typ]
        found = []
        for vr in vrs:
            var = self.obj.vars.get(vr)
            acc = None if var is None else (var.getter if op == "get" else var.setter)
            if not isinstance(var, kind) or acc is None:
                return None
            found.append(acc)
        return found

    def _bound(self, op, typ, vrs):
        """The slave's own fast accessor, if its class offers ``cosim_bind(op, typ, vrs)`` (documented in
        docs/architecture.md: a function equivalent to get_<typ>(vrs) / set_<typ>(vrs, values))."""
        return _shell_bind(self.obj, op, typ, vrs)

    def bound_get(self, typ, port):
        obj, buf, vrs, conv = self.obj, port.buf, port.extra, _CONVERT[typ]
        drain, get_port = self._drain, self.get_port
        # Real and Integer values go into a float64 or integer buffer, which converts them as float() or int()
        # would: the slave may hand them over unconverted (``get_raw``: one C-level attribute fetch, no list, no
        # Python frame); a Boolean buffer holds 0/1 either way, but a String one would keep a non-str
        as_is = typ == "Real" or (typ == "Integer" and buf.dtype.kind in "iu")
        raw = self._bound("get_raw", typ, vrs) if as_is else None
        if raw is not None:
            fetch, single = raw
            retry = functools.partial(get_port, typ, port)
            fetch, src, keys = self._from_dict(fetch)
            if single:
                def op():
                    try:
                        buf[0] = fetch(src)
                    except Exception:
                        return get_port(typ, port)        # again through the reporting path
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("single", fetch, src, keys, buf, None, retry, obj, drain)
            elif buf.flags.c_contiguous and buf.flags.writeable and buf.dtype.isnative:
                # struct writes the values into the buffer's memory in one C loop (numpy's assignment from a
                # tuple converts value by value); a value struct does not take as is raises, and the reporting
                # path below stores it through numpy as before
                pack_into = struct.Struct(f"@{len(buf)}{buf.dtype.char}").pack_into
                mem = memoryview(buf).cast("B")     # the same memory, a cheaper buffer to ask for than numpy's

                def op():
                    try:
                        pack_into(mem, 0, *fetch(src))
                    except Exception:
                        return get_port(typ, port)
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("pack", fetch, src, keys, mem, pack_into, retry, obj, drain)
            else:
                def op():
                    try:
                        buf[:] = fetch(src)
                    except Exception:
                        return get_port(typ, port)
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("assign", fetch, src, keys, buf, None, retry, obj, drain)
            return op
        read = self._reader(typ, vrs, buf, conv)

        # one frame per call: the read inlined, the log queue looked at only when it holds a message
        def op():
            try:
                read()
            except Exception:
                return get_port(typ, port)        # again through the reporting path
            if obj.log_queue:
                drain()
            return OK
        return op

    def _from_dict(self, fetch):
        """(fetch, what it is called with, the keys it reads or None): an attrgetter of plain instance attributes becomes an itemgetter of the
        same names on the instance's __dict__ (the attribute look-up without its search of the class for a
        descriptor: the same values, as the shell's ``set_raw`` writes them there); else ``fetch`` on the instance."""
        obj = self.obj
        if type(fetch) is not operator.attrgetter or type(obj).__getattribute__ is not object.__getattribute__:
            return fetch, obj, None
        names = fetch.__reduce__()[1]
        d = obj.__dict__
        if not all(type(n) is str and n in d and not hasattr(type(obj), n) for n in names):
            return fetch, obj, None
        return operator.itemgetter(*names), d, tuple(names)

    def _reader(self, typ, vrs, buf, conv):
        """A function filling ``buf`` with the values of ``vrs``: the slave's own fast accessor where it has
        one, else its getters, else its get_<typ>."""
        obj = self.obj
        bound = self._bound("get", typ, vrs)
        if bound is not None:
            if len(vrs) == 1:
                def read():
                    buf[0] = bound()[0]
            else:
                def read():
                    buf[:] = bound()
            return read
        getters = self._direct("get", typ, vrs)
        if getters is not None and len(getters) == 1:
            g = getters[0]

            def read():
                buf[0] = conv(g())
        elif getters is not None:
            def read():
                buf[:] = [conv(g()) for g in getters]
        else:
            method = getattr(obj, f"get_{typ.lower()}")

            def read():
                buf[:] = method(vrs)
        return read

    def bound_set(self, typ, port):
        obj, buf, vrs, conv = self.obj, port.buf, port.extra, _CONVERT[typ]
        bound = self._bound("set", typ, vrs)
        setters = None if bound is not None else self._direct("set", typ, vrs)
        method = getattr(obj, f"set_{typ.lower()}")
        drain, set_port, tolist = self._drain, self.set_port, buf.tolist
        # a float or integer buffer's tolist() holds Python floats or ints already: nothing to convert (a
        # Boolean buffer holds 0/1, which bool() makes True/False)
        as_is = typ == "Real" or (typ == "Integer" and buf.dtype.kind in "iu")
        raw = self._bound("set_raw", typ, vrs) if as_is else None
        if raw is not None:
            update, names = raw          # the slave's own attribute update, called inline: no Python frame

            def op():
                try:
                    update(zip(names, tolist()))
                except Exception:
                    return set_port(typ, port)
                if obj.log_queue:
                    drain()
                return OK
            return op
        if bound is not None and as_is:
            def write():
                bound(tolist())
        elif bound is not None:
            def write():
                bound([conv(v) for v in tolist()])
        elif setters is not None and len(setters) == 1:
            s0 = setters[0]

            def write():
                s0(conv(buf[0]))
        elif setters is not None:
            def write():
                for s, v in zip(setters, tolist()):
                    s(conv(v))
        else:
            def write():
                method(vrs, [conv(v) for v in tolist()])

        def op():
            try:
                write()
            except Exception:
                return set_port(typ, port)
            if obj.log_queue:
                drain()
            return OK
        return op

    def bound_cycle(self, write_ports, calls, index):
        """Inputs and doStep in one call when every input port has the slave's inline update (``set_raw``): the
        same work as the setters and the step bound one by one, without a frame and a status test per port."""
        raws = []
        for typ, port in write_ports:
            raw = self._bound("set_raw", typ, port.extra) if (
                typ == "Real" or (typ == "Integer" and port.buf.dtype.kind in "iu")) else None
            if raw is None:
                return None
            raws.append((raw[0], raw[1], port.buf.tolist))
        obj, do_step, drain, set_port = self.obj, self.obj.do_step, self._drain, self.set_port
        step_error = self._step_error

        def failed():
            """A setter raised: the ports again through the reporting path, in order, up to the failing one
            (its status + SET_FAILED); None when they all go through this time (then the step goes on)."""
            for typ, port in write_ports:
                st = set_port(typ, port)
                if st > WARNING:
                    return SET_FAILED + st
            return None

        def step(t, h):
            calls[index] += 1
            try:
                ok = do_step(t, h)
            except Exception:
                return step_error(t, h)
            if obj.log_queue:
                drain()
            return OK if ok else DISCARD

        def sets_failed():
            st = failed()
            return 0 if st is None else st - SET_FAILED

        if not raws:
            step.inline = InlineCycle((), sets_failed, do_step, step_error, obj, drain)
            return step

        def op(t, h):
            try:
                for u, n, l in raws:
                    u(zip(n, l()))
            except Exception:
                if (st := failed()) is not None:
                    return st
            return step(t, h)
        op.inline = InlineCycle(tuple(raws), sets_failed, do_step, step_error, obj, drain)
        return op

    def bound_step(self):
        obj = self.obj
        do_step = obj.do_step

        def op(t, h):
            try:
                ok = do_step(t, h)
            except Exception:
                return self._step_error(t, h)
            if obj.log_queue:
                self._drain()
            return OK if ok else DISCARD
        return op

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
