"""Importing a pythonfmu FMU's slave module in process, so that the FMU runs the code it bundles (as its binary,
which runs each FMU in its own interpreter state, does).

A top-level name the FMU's resources provide (``uavsim``, its slave module) may already be imported from elsewhere
(the installed package, or another FMU's copy). When every such name is unimported or imported from
byte-identical .py files, the FMU is imported as usual (shared modules, no cost); otherwise it is loaded in
isolation (:class:`_Isolated`): its own copies of all the names its resources provide, kept apart from
sys.modules.
"""
from __future__ import annotations

import builtins
import hashlib
import importlib
import importlib.machinery
import importlib.util
import sys
import threading
from functools import lru_cache
from pathlib import Path

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
