"""One registry per extension kind: algorithms, monitors, observers, sinks, scenario kinds.

Built-in extensions register themselves when their module is imported: a package either names each built-in's
module in a table (``{"jacobi": "master.algorithms.jacobi"}``: a look-up imports that module only, so a run imports
the one algorithm it uses) or imports every module of its folder on the first look-up (``import_submodules``).
Installed packages publish theirs under an entry point group (``cosim_master.<kind>``: name = the key, value =
``module:object``), read once per process for every group and loaded only when their name is looked up. The CLI,
the SSD settings annotation, campaigns and scenario files all look names up here, so a new name is known everywhere
at once.

A plugin that is named but fails to load is an error, never a silent fallback: a UAV scenario whose
monitor cannot be imported must not run without it.
"""
from __future__ import annotations

from typing import Callable, Generic, Iterator, Mapping, TypeVar

from .errors import CosimError

T = TypeVar("T")

_INSTALLED = None                   # the entry points of every installed distribution, read once per process
_BY_GROUP: dict[str, dict] = {}     # group -> name -> entry point


def entry_points_of(group: str) -> dict:
    """The entry points of ``group`` by name. The installed distributions are read once per process for all groups
    (reading them costs the same for one group as for all, ~10 ms with importing importlib.metadata), so that the
    registries of a run share one scan; nothing is imported."""
    global _INSTALLED
    if group not in _BY_GROUP:
        if _INSTALLED is None:
            from importlib.metadata import entry_points
            _INSTALLED = entry_points()
        _BY_GROUP[group] = {ep.name: ep for ep in _INSTALLED.select(group=group)}
    return _BY_GROUP[group]


class Registry(Generic[T]):
    def __init__(self, kind: str, group: str,
                 builtins: Mapping[str, str] | Callable[[], None] | None = None):
        self.kind = kind                  # shown in messages: "algorithm", "monitor", ...
        self.group = group                # entry point group
        self._items: dict[str, T] = {}
        # the built-ins: name -> module imported when the name is looked up, or a loader importing them all
        self._table: dict[str, str] = dict(builtins) if isinstance(builtins, Mapping) else {}
        self._builtins = None if isinstance(builtins, Mapping) else builtins
        self._builtins_loaded = self._builtins is None

    # -- registration ----------------------------------------------------------------------------------
    def register(self, name: str, obj: T | None = None, *, replace: bool = False):
        """``REG.register("name", obj)`` or, as a class decorator, ``@REG.register("name")``."""
        def add(o):
            if not replace and name in self._items and self._items[name] is not o:
                raise CosimError(f"{self.kind} {name!r} is registered twice ({self._items[name]!r} and {o!r})",
                                 element=self.group)
            self._items[name] = o
            if isinstance(o, type) and getattr(o, "registered_name", None) in (None, ""):
                o.registered_name = name
            return o
        return add if obj is None else add(obj)

    def unregister(self, name: str) -> None:
        self._items.pop(name, None)

    # -- look-up ---------------------------------------------------------------------------------------
    def _load_builtins(self):
        if not self._builtins_loaded:
            self._builtins_loaded = True
            self._builtins()

    def _scan(self) -> dict:
        return entry_points_of(self.group)

    def _builtin(self, name: str) -> T:
        """The built-in the table names: its module imported, which registers it."""
        import importlib
        module = self._table[name]
        importlib.import_module(module)
        if name not in self._items:
            raise CosimError(f"the built-in {self.kind} {name!r} is not registered by {module}", element=self.group)
        return self._items[name]

    def _load(self, name: str) -> T | None:
        ep = self._scan().get(name)
        if ep is None:
            return None
        try:
            obj = ep.load()
        except Exception as exc:  # noqa: BLE001 - any import failure of a named plugin is the user's error
            raise CosimError(f"the {self.kind} {name!r} is installed ({ep.value}) but cannot be loaded: "
                             f"{type(exc).__name__}: {' '.join(str(exc).split())}", element=self.group) from None
        if name not in self._items:
            self.register(name, obj)
        return self._items[name]

    def get(self, name: str, *, element: str | None = None) -> T:
        found = self.find(name)
        if found is None:
            raise CosimError(f"unknown {self.kind} {name!r} (known: {', '.join(self.names()) or 'none'})",
                             element=element or self.group)
        return found

    def find(self, name: str) -> T | None:
        """The extension registered as ``name``, or None when there is none (an entry point that fails to
        load raises)."""
        self._load_builtins()
        if name in self._items:
            return self._items[name]
        if name in self._table:
            return self._builtin(name)
        return self._load(name)

    def names(self) -> list[str]:
        """Every name, built-in, registered at run time or published by an installed package."""
        self._load_builtins()
        return sorted(set(self._items) | set(self._table) | set(self._scan()))

    def load_all(self) -> dict[str, T]:
        for name in self.names():
            self.find(name)
        return dict(self._items)

    def __getitem__(self, name: str) -> T:
        return self.get(name)

    def __contains__(self, name: str) -> bool:
        """Is ``name`` known (nothing is imported; the installed packages are read only for a name that is not
        built in)? A registry is the ``choices`` of a command-line option this way (give it a ``metavar``: argparse
        lists the choices of one without, which would import them all)."""
        self._load_builtins()
        return name in self._items or name in self._table or name in self._scan()

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())


def import_submodules(package: str) -> Callable[[], None]:
    """A ``builtins`` loader that imports every module of ``package`` (so that each registers itself)."""
    def load():
        import importlib
        import pkgutil
        pkg = importlib.import_module(package)
        for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda i: i.name):
            if not info.name.startswith("_"):
                importlib.import_module(f"{package}.{info.name}")
    return load
