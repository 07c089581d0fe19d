"""What a plan is made of: the variables (``Var``), the links between them and the plan itself, as the
runtime, the observers and the algorithms read them.  Made by :mod:`.build`."""
from __future__ import annotations

import itertools
import operator
from collections.abc import Mapping
from pathlib import Path

from ..errors import ScenarioError
from ..fmi.cache import LoadedFmu
from ..records import Record, replaced
from ..ssp.model import SystemModel


_VAR_FIELDS = ("component", "name", "vr", "type", "fmi_type", "causality", "variability", "unit", "shape", "index",
               "array", "start")
_var_key = operator.attrgetter(*_VAR_FIELDS)


class Var:
    """A variable of a component as the plan moves it.  Immutable and hashable by its fields, as the frozen
    dataclass it was, but a plain class (``master.records`` says why; its field ``index`` rules out a named
    tuple, whose ``index`` is a method)."""
    def __init__(self, component: str, name: str, vr: int, type: str, fmi_type: str, causality: str,
                 variability: str, unit: str | None, shape: tuple = (), index: int | None = None,
                 array: str | None = None, start: object = None):
        d = self.__dict__
        d["component"], d["name"], d["vr"] = component, name, vr
        d["type"] = type                # base type: Real, Integer, Boolean, String
        d["fmi_type"] = fmi_type        # the FMU's own type name
        d["causality"], d["variability"], d["unit"] = causality, variability, unit
        # FMI 3.0 arrays: the whole array has a shape and no index; each element is a Var of its own, named
        # ``y[1]``, ``A[2,1]`` (1-based, row-major as FMI 3 stores them), with its flat 0-based index and its array
        d["shape"], d["index"], d["array"] = shape, index, array
        d["start"] = start              # elements and arrays only: the modelDescription's start value(s)

    def changed(self, **fields) -> "Var":
        """The same variable with ``fields`` changed (what ``dataclasses.replace`` made; an unknown name is the same
        TypeError)."""
        return Var(**{**self.__dict__, **fields})

    # equality and hash as the dataclass made them: the fields in order (one C call reads them, no Python call per
    # comparison: a plan compares and hashes Vars in its dictionaries)
    def __eq__(self, other):
        if other.__class__ is not self.__class__:
            return NotImplemented
        return _var_key(self) == _var_key(other)

    def __hash__(self):
        return hash(_var_key(self))

    def __repr__(self):
        d = self.__dict__
        return f"Var({', '.join(f'{f}={d[f]!r}' for f in _VAR_FIELDS)})"

    def __setattr__(self, name, value):
        from dataclasses import FrozenInstanceError     # the frozen dataclass's error, imported when it is raised
        raise FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name):
        from dataclasses import FrozenInstanceError
        raise FrozenInstanceError(f"cannot delete field {name!r}")

    @property
    def qualified(self) -> str:
        return f"{self.component}.{self.name}"

    @property
    def is_array(self) -> bool:
        """The whole array (its elements are what the master moves and records)."""
        return bool(self.shape) and self.index is None


def element_names(name: str, shape: tuple) -> list[str]:
    return [f"{name}[{','.join(str(i + 1) for i in idx)}]" for idx in itertools.product(*map(range, shape))]


class Link(Record):
    """A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, src: Var, dst: Var, factor: float = 1.0, offset: float = 0.0, mapping: dict | None = None,
                 line: int | None = None):
        self.src, self.dst, self.factor, self.offset, self.mapping, self.line = src, dst, factor, offset, mapping, line

    def between(self, src: Var, dst: Var) -> "Link":
        """The same link (conversion, line) between ``src`` and ``dst``."""
        return Link(src, dst, self.factor, self.offset, self.mapping, self.line)


class Plan(Record):
    """A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, model: SystemModel, shown_as: str, fmus: dict[str, LoadedFmu], links: list[Link],
                 params: list[tuple[Var, object, str]], feedthrough: dict[str, dict[str, set | None]],
                 variables: dict[str, dict[str, Var]] | None = None):
        self.model, self.shown_as, self.fmus, self.links, self.params = model, shown_as, fmus, links, params
        self.feedthrough = feedthrough      # component -> output -> inputs it depends on (None: all)
        self.variables = {} if variables is None else variables

    def elements(self, v: Var) -> list[Var]:
        """Every element of the array ``v`` is (or belongs to), in FMI 3 order."""
        whole = self.variables[v.component][v.array or v.name]
        return [self.variables[v.component][n] for n in element_names(whole.name, whole.shape)]

    def var(self, qualified: str) -> Var:
        comp, _, name = self.split(qualified)
        return self.variables[comp][name]

    def split(self, qualified: str):
        """Split 'a.b.c.var' into component and variable, preferring the longest known component name."""
        best = None
        cut = qualified.rfind(".")
        while cut > 0:                        # longest prefix first: one dictionary look-up per dot
            if qualified[:cut] in self.variables:
                best = qualified[:cut]
                break
            cut = qualified.rfind(".", 0, cut)
        if best is None:
            raise ScenarioError(f"{qualified!r} does not start with a component name "
                                f"(components: {', '.join(self.variables)})", file=self.shown_as)
        name = qualified[len(best) + 1:]
        if name not in self.variables[best]:
            raise ScenarioError(f"component {best!r} has no variable {name!r}", file=self.shown_as)
        return best, ".", name


class ComponentVariables(Mapping):
    """A component's variables by name, each Var made when first asked for from its FMU's description (shared
    by every component of that FMU).  A run asks for a few dozen of them (connectors, parameters, recorded
    outputs); a Var per variable and component was 55 MB of a 256-UAV fleet's plan, whose strategy FMUs have
    1211 variables each.  Iterating makes them all."""

    __slots__ = ("component", "_described", "_made")

    def __init__(self, component: str, described: dict[str, Var]):
        self.component = component
        self._described = described
        self._made: dict[str, Var] = {}

    def __getitem__(self, name: str) -> Var:
        v = self._made.get(name)
        if v is None:
            v = self._made[name] = replaced(self._described[name], component=self.component)
        return v

    def __contains__(self, name) -> bool:
        return name in self._described

    def get(self, name, default=None):
        return self[name] if name in self._described else default

    def __iter__(self):
        return iter(self._described)

    def __len__(self) -> int:
        return len(self._described)

    @property
    def described(self) -> dict[str, Var]:
        """The FMU's variables with no component (shared by every component of the FMU, never modified): what
        a per-process cache may key on by identity."""
        return self._described


def shown_source(shown_as: str, source: str) -> str:
    """How a file of the scenario is named in messages: inside the archive or folder the user named, or beside
    a bare .ssd (not under the .ssd's own name)."""
    if not shown_as:
        return source
    if shown_as.lower().endswith(".ssd"):
        return str(Path(shown_as).parent / source)
    return f"{shown_as}/{source}"
