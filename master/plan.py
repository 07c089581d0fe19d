"""Checking a parsed system against its FMUs and resolving it to value references, before anything runs.

Every mismatch between the SSD and an FMU's modelDescription (unknown connector, type, causality,
unit dimension) is reported here, so that no FMU is instantiated for a scenario that cannot run.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from .errors import CosimError, ScenarioError
from .fmi.cache import LoadedFmu, load_fmu
from .fmi.factory import choose_kind
from .fmi.slave import INTEGER_BASES, OBJECT_FILL, array_shape, base_type
from .fmi.table import TableColumn, column_values, csv_source, read_csv_table
from .ssp.model import CSV_SOURCE_TYPE, Component, Connection, Connector, SystemModel
from .units import conversion, unit_from_fmu
from .values import parse_text

# SSD connector kinds and the FMU causalities they may describe
KIND_CAUSALITY = {
    "input": {"input"},
    "output": {"output"},
    "parameter": {"parameter", "structuralParameter"},
    "calculatedParameter": {"calculatedParameter"},
}
# SSD connector types and the FMU variable types they may describe
SSD_TYPE_FMI = {
    "Real": {"Real", "Float64", "Float32"},
    # an FMU enumeration is an integer to a connector; ssc:Enumeration would need a named SSD enumeration, which
    # our writer and most tools do not write
    "Integer": {"Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Enumeration"},
    "Boolean": {"Boolean"},
    "String": {"String"},
    "Enumeration": {"Enumeration"},
    "Binary": {"Binary"},
}


@dataclass(frozen=True)
class Var:
    component: str
    name: str
    vr: int
    type: str          # base type: Real, Integer, Boolean, String
    fmi_type: str      # the FMU's own type name
    causality: str
    variability: str
    unit: str | None
    # FMI 3.0 arrays: the whole array has a shape and no index; each element is a Var of its own, named
    # ``y[1]``, ``A[2,1]`` (1-based, row-major as FMI 3 stores them), with its flat 0-based index and its array
    shape: tuple = ()
    index: int | None = None
    array: str | None = None
    start: object = None            # elements and arrays only: the modelDescription's start value(s)

    @property
    def qualified(self) -> str:
        return f"{self.component}.{self.name}"

    @property
    def is_array(self) -> bool:
        """The whole array (its elements are what the master moves and records)."""
        return bool(self.shape) and self.index is None


def element_names(name: str, shape: tuple) -> list[str]:
    return [f"{name}[{','.join(str(i + 1) for i in idx)}]" for idx in itertools.product(*map(range, shape))]


@dataclass
class Link:
    src: Var
    dst: Var
    factor: float = 1.0
    offset: float = 0.0
    mapping: dict | None = None
    line: int | None = None


@dataclass
class Plan:
    model: SystemModel
    shown_as: str
    fmus: dict[str, LoadedFmu]
    links: list[Link]
    params: list[tuple[Var, object, str]]
    feedthrough: dict[str, dict[str, set | None]]   # component -> output -> inputs it depends on (None: all)
    variables: dict[str, dict[str, Var]] = field(default_factory=dict)

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


def _var(comp: str, fmu: LoadedFmu, v) -> Var:
    unit = getattr(v, "unit", None)
    if unit is None and getattr(v, "declaredType", None) is not None:
        unit = getattr(v.declaredType, "unit", None)
    bt = base_type(fmu.fmi_version, v.type)
    return Var(comp, v.name, int(v.valueReference), bt or v.type, v.type, v.causality, v.variability, unit)


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
            v = self._made[name] = _renamed(self._described[name], self.component)
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


def _renamed(v: Var, component: str) -> Var:
    """``replace(v, component=component)`` without dataclasses.replace's field-by-field construction (a run makes
    a few hundred of them; a Var is a frozen record of plain fields, so its copy is its __dict__)."""
    out = object.__new__(Var)
    d = out.__dict__
    d.update(v.__dict__)
    d["component"] = component
    return out


# model description -> (the description, kept alive for its id; its variables, component ""): a campaign worker
# plans the same FMUs run after run, and an FMU with a thousand variables costs milliseconds to describe
_VARIABLES: dict[int, tuple[object, dict[str, Var]]] = {}


def _component_variables(comp: str, fmu: LoadedFmu) -> ComponentVariables:
    """Every variable by name; an FMI 3.0 array also as its elements."""
    cached = _VARIABLES.get(id(fmu.md))
    if cached is None or cached[0] is not fmu.md:
        cached = _VARIABLES[id(fmu.md)] = (fmu.md, _describe_variables("", fmu))
    return ComponentVariables(comp, cached[1])


def _describe_variables(comp: str, fmu: LoadedFmu) -> dict[str, Var]:
    by_vr = {v.valueReference: v for v in fmu.md.modelVariables}
    out = {}
    for mv in fmu.md.modelVariables:
        v = out[mv.name] = _var(comp, fmu, mv)
        shape = array_shape(mv, by_vr)
        if not shape:
            continue
        names = element_names(v.name, shape)
        start = _array_start(v, mv.start, len(names))
        out[v.name] = replace(v, shape=shape, start=start)
        for k, name in enumerate(names):
            out[name] = replace(v, name=name, shape=shape, index=k, array=v.name, start=start[k])
    return out


def _array_start(v: Var, text, size: int) -> tuple:
    """The start values of an array (a space-separated list in FMI 3), zeros (or false, "") when it has none."""
    if text is None:
        return (({"Real": 0.0, "Boolean": False, **OBJECT_FILL}).get(v.type, 0),) * size
    return tuple(parse_value(v, raw, v.qualified, allow_nonfinite=True) for raw in str(text).split())


def _structural_sizes(variables: dict[str, Var], fmu: LoadedFmu) -> dict[str, list[str]]:
    """Structural parameter name -> the arrays whose dimensions it gives."""
    by_vr = {v.valueReference: v.name for v in fmu.md.modelVariables}
    sizes: dict[str, list[str]] = {}
    for mv in fmu.md.modelVariables:
        for d in getattr(mv, "dimensions", None) or ():
            if d.start is None:
                sizes.setdefault(by_vr[d.valueReference], []).append(mv.name)
    return sizes


def _element_feedthrough(plan_vars: dict[str, Var], outs: dict) -> dict:
    """Output dependencies for array elements: an element depends on what its array does, and a dependency on
    an input array is one on each of its elements."""
    def expand(deps):
        if deps is None:
            return None
        return {e for d in deps for e in ([d] if not plan_vars[d].is_array else
                                          element_names(d, plan_vars[d].shape))}
    result = {name: expand(deps) for name, deps in outs.items()}
    for name, deps in list(result.items()):
        if plan_vars[name].is_array:
            result.update(dict.fromkeys(element_names(name, plan_vars[name].shape), deps))
    return result


def build_plan(model: SystemModel, shown_as: str, params: dict[str, object] | None = None,
               allow_nonfinite: bool = False, lenient: bool = False,
               implementation: dict[str, str] | None = None, inputs=None) -> Plan:
    """``lenient``: modelDescription.xml files are read as far as the master can use them (see
    ``fmi.cache.load_fmu``); ``implementation``: component -> "ModelExchange" / "CoSimulation" / "any",
    over the SSD's implementation attribute; ``inputs``: a CSV file whose columns drive the inputs of the
    scenario's one FMU (``run --input``, the FMI cross-check ``_in.csv`` format)."""
    unknown = sorted(set(implementation or {}) - set(model.components))
    if unknown:
        raise ScenarioError(f"implementation given for unknown component{'s' if len(unknown) > 1 else ''} "
                            f"{', '.join(unknown)}", file=shown_as, element="implementation")
    key, loaded = _plan_key(model, shown_as, lenient, implementation, inputs)
    known = _PLANS.get(key) if key is not None else None
    if known is None:
        fmus, variables, feed, units, links = _plan_structure(model, shown_as, lenient, implementation, inputs)
        if key is not None:
            _keep_plan(key, fmus, variables, feed, units, links)
    else:
        fmus, variables, feed, units, links = known.for_run(model, loaded)
    plan = Plan(model, shown_as, fmus, links, [], feed, variables)
    _add_parameters(plan, model, units, allow_nonfinite)
    add_overrides(plan, params, allow_nonfinite)
    return plan


def _plan_structure(model: SystemModel, shown_as: str, lenient: bool, implementation: dict | None, inputs):
    """The part of a plan its parameter values do not change: the FMUs (and the kind each component runs as),
    every component's variables and output dependencies, the units and the links, all checked."""
    fmus: dict[str, LoadedFmu] = {}
    variables: dict[str, dict[str, Var]] = {}
    feed: dict[str, dict[str, set | None]] = {}
    for name, comp in model.components.items():
        if comp.type != CSV_SOURCE_TYPE:
            kind = (implementation or {}).get(name) or comp.implementation
            fmus[name], variables[name], feed[name] = _fmu_component(name, comp, kind, shown_as, lenient)
    if inputs is not None:
        _add_input_file(model, Path(inputs), variables, shown_as)
    # input tables last: their columns take the types of the FMU inputs they drive
    for name, comp in model.components.items():
        if comp.type == CSV_SOURCE_TYPE:
            fmus[name], variables[name] = _csv_component(name, comp, model, variables, shown_as)
            feed[name] = {column: set() for column in variables[name]}
    fmus = {name: fmus[name] for name in model.components}              # declaration order, as the SSD has it
    variables = {name: variables[name] for name in model.components}
    units = _unit_table(model, fmus)
    links = [ln for c in model.connections for ln in _array_links(_link(c, model, variables, units, shown_as),
                                                                   variables, shown_as)]
    seen: dict[str, Link] = {}
    for ln in links:
        key = ln.dst.qualified
        if key in seen:
            raise ScenarioError(f"input {key} is the end of two connections (from {seen[key].src.qualified} and "
                                f"{ln.src.qualified})", file=shown_as, element=f"Connection -> {key}", line=ln.line)
        seen[key] = ln
    return fmus, variables, feed, units, links


def _add_parameters(plan: Plan, model: SystemModel, units: dict, allow_nonfinite: bool) -> None:
    """The SSD's parameter values, checked against their variables (and converted to their units)."""
    variables = plan.variables
    for pv in model.parameters:
        v = variables.get(pv.component, {}).get(pv.variable)
        where = f"Parameter {pv.component}.{pv.variable}"
        if v is None:
            raise ScenarioError(f"no variable {pv.variable!r} in component {pv.component!r}",
                                file=pv.origin.rsplit(":", 1)[0], element=where, line=_line(pv.origin))
        if v.is_array:
            raise ScenarioError(f"{v.qualified} is an array: give its elements ({element_names(v.name, v.shape)[0]}, "
                                "...) one by one", file=pv.origin.rsplit(":", 1)[0], element=where,
                                line=_line(pv.origin))
        value = _check_value(v, pv.value, pv.type, pv.origin, where)
        why = value_error(v, value, allow_nonfinite)
        if why:
            raise ScenarioError(why, file=pv.origin.rsplit(":", 1)[0], element=where, line=_line(pv.origin))
        src_unit = getattr(pv, "unit", None)
        if v.type == "Real" and src_unit and v.unit and src_unit != v.unit:
            for u in (src_unit, v.unit):
                if units.get(u) is None:
                    raise ScenarioError(f"unit {u} has no definition in the SSD or the FMU, so {src_unit} cannot "
                                        f"be converted to {v.unit}", file=pv.origin.rsplit(":", 1)[0], element=where,
                                        line=_line(pv.origin))
            conv = conversion(units.get(src_unit), units.get(v.unit))
            if conv is None:
                raise ScenarioError(f"unit {src_unit} cannot be converted to {v.unit}",
                                    file=pv.origin.rsplit(":", 1)[0], element=where, line=_line(pv.origin))
            value = conv[0] * value + conv[1]
        plan.params.append((v, value, pv.origin))


@dataclass(frozen=True)
class _PlanStructure:
    """The value-free part of a plan (:func:`_plan_structure`) kept for later runs of the same structure and FMUs;
    never handed out itself: each run gets its own links, dependency sets and dictionaries."""
    kinds: dict             # component -> the FMI kind it runs as
    variables: dict         # component -> ComponentVariables (read-only mappings of frozen Vars)
    feedthrough: dict
    units: dict
    links: tuple

    def for_run(self, model: SystemModel, loaded: dict):
        """The run's own plan parts, with its FMUs (``loaded``: by file, as _plan_key loaded them)."""
        fmus = {name: dataclasses.replace(loaded[comp.fmu_path], kind=self.kinds[name])
                for name, comp in model.components.items()}
        return fmus, dict(self.variables), _copied_feedthrough(self.feedthrough), dict(self.units), \
            [_clone(ln) for ln in self.links]


# (structure key, each component's FMU content and kind asked for, lenient, units) -> _PlanStructure: a campaign
# worker plans the same system against the same FMUs run after run, with other parameter values
_PLANS: dict[tuple, _PlanStructure] = {}
_MAX_PLANS = 32
_MAX_KEPT_LINKS = 100_000       # links of all kept plans (4 UAVs: ~60; 256 UAVs: ~4000)


def _loaded_fmus(model: SystemModel, shown_as: str, lenient: bool) -> dict:
    """Each FMU file of the model, loaded (once per file: a fleet's components share a few)."""
    loaded = {}
    for comp in model.components.values():
        if comp.fmu_path not in loaded:
            loaded[comp.fmu_path] = load_fmu(comp.fmu_path, shown_source(shown_as, comp.source), lenient=lenient)
    return loaded


def _plan_key(model: SystemModel, shown_as: str, lenient: bool, implementation: dict | None,
              inputs) -> tuple[tuple | None, dict]:
    """What the value-free part of the plan depends on: the structure, the FMUs by content, the options that
    change it, and the units (a parameter set may define some); with the FMUs loaded to find their contents.
    None: not to be reused (the model was not read for it, an input file or table is read per run, or an FMU
    fails to load: the full plan says why)."""
    if model.structure is None or inputs is not None:
        return None, {}
    if any(comp.type == CSV_SOURCE_TYPE for comp in model.components.values()):
        return None, {}
    try:
        loaded = _loaded_fmus(model, shown_as, lenient)
    except CosimError:
        return None, {}
    fmus = tuple((name, loaded[comp.fmu_path].sha256, (implementation or {}).get(name) or comp.implementation)
                 for name, comp in model.components.items())
    units = repr([(name, u.name, u.factor, u.offset, u.exponents) for name, u in model.units.items()])  # -0.0
    return (model.structure, fmus, bool(lenient), units), loaded


def _keep_plan(key: tuple, fmus: dict, variables: dict, feed: dict, units: dict, links: list) -> None:
    if len(_PLANS) >= _MAX_PLANS or sum(len(p.links) for p in _PLANS.values()) + len(links) > _MAX_KEPT_LINKS:
        _PLANS.clear()          # emptied when full (a campaign plans a handful of systems): no order to keep
    if len(links) > _MAX_KEPT_LINKS:
        return
    _PLANS[key] = _PlanStructure({name: f.kind for name, f in fmus.items()}, dict(variables),
                                 _copied_feedthrough(feed), dict(units), tuple(_clone(ln) for ln in links))


def _clone(obj):
    """A shallow copy of a plain dataclass instance (copy.copy's reduce protocol cost more than the rest of a reused
    plan)."""
    out = object.__new__(type(obj))
    out.__dict__.update(obj.__dict__)
    return out


def _copied_feedthrough(feed: dict) -> dict:
    return {comp: {out: None if deps is None else set(deps) for out, deps in outs.items()}
            for comp, outs in feed.items()}


def _fmu_component(name: str, comp: Component, implementation: str, shown_as: str, lenient: bool):
    """An FMU component's loaded FMU (with the kind it runs as), variables and output dependencies, its SSD
    connectors checked against them."""
    where = f"Component {name}"
    fmu = load_fmu(comp.fmu_path, shown_source(shown_as, comp.source), lenient=lenient)
    try:
        kind = choose_kind(fmu, implementation)
    except ValueError as exc:
        raise ScenarioError(str(exc), file=shown_as, element=where, line=comp.line) from None
    variables = _component_variables(name, fmu)
    for conn in comp.connectors.values():
        v = variables.get(conn.name)
        if v is None:
            raise ScenarioError(f"the FMU {comp.source} has no variable {conn.name!r}", file=shown_as,
                                element=f"Connector {name}.{conn.name}", line=conn.line)
        _check_connector(conn, v, shown_as)
    outs = {}
    for u in fmu.md.outputs:
        deps = u.dependencies   # None: the FMU did not say, so it may depend on every input
        outs[u.variable.name] = None if deps is None else {d.name for d in deps if d.causality == "input"}
    return dataclasses.replace(fmu, kind=kind), variables, _element_feedthrough(variables, outs)


def _check_connector(conn: Connector, v: Var, shown_as: str) -> None:
    """The SSD connector ``conn`` describes ``v``: its kind, type and a type the master can connect."""
    here = f"Connector {v.qualified}"
    allowed = KIND_CAUSALITY.get(conn.kind)
    if allowed is None:
        raise ScenarioError(f"connector kind {conn.kind!r} is not allowed on a component", file=shown_as,
                            element=here, line=conn.line)
    if v.causality not in allowed:
        raise ScenarioError(f"kind {conn.kind!r} does not match the FMU's causality {v.causality!r}",
                            file=shown_as, element=here, line=conn.line)
    if conn.type is not None and v.fmi_type not in SSD_TYPE_FMI.get(conn.type, set()):
        raise ScenarioError(f"type {conn.type} does not match the FMU's type {v.fmi_type}", file=shown_as,
                            element=here, line=conn.line)
    if v.type not in ("Real", *INTEGER_BASES, "Boolean", *OBJECT_FILL):
        raise ScenarioError(f"variables of type {v.fmi_type} cannot be connected", file=shown_as,
                            element=here, line=conn.line)


# -- input tables (fmi/table.py) -------------------------------------------------------------------------------
INPUT_FILE_COMPONENT = "inputs"


def _add_input_file(model: SystemModel, path: Path, variables: dict, shown_as: str) -> None:
    """``run --input FILE``: the file as an input table whose columns drive the inputs of the scenario's one FMU
    of the same names."""
    targets = [name for name, comp in model.components.items() if comp.type != CSV_SOURCE_TYPE]
    if len(targets) != 1:
        raise ScenarioError(f"--input drives the inputs of a scenario with one FMU; this one has {len(targets)} "
                            f"({', '.join(targets)})", file=shown_as, element="--input")
    if INPUT_FILE_COMPONENT in model.components:
        raise ScenarioError(f"the scenario has a component named {INPUT_FILE_COMPONENT!r} already, the name --input "
                            "gives its table", file=shown_as, element="--input")
    target, columns = targets[0], list(read_csv_table(path, str(path)).columns)
    inputs = sorted(n for n, v in variables[target].items() if v.causality == "input" and not v.is_array)
    unknown = [c for c in columns if c not in inputs]
    if unknown:
        raise ScenarioError(f"column {unknown[0]!r} is not an input of {target} (its inputs: "
                            f"{', '.join(inputs) or 'none'})", file=str(path), element="--input")
    model.components[INPUT_FILE_COMPONENT] = Component(INPUT_FILE_COMPONENT, str(path), path, CSV_SOURCE_TYPE,
                                                       {c: Connector(c, "output") for c in columns})
    model.connections += [Connection(INPUT_FILE_COMPONENT, c, target, c) for c in columns]


def _csv_component(name: str, comp: Component, model: SystemModel, variables: dict, shown_as: str):
    """An input table's stand-in for an FMU and its variables: one per connected column, typed as the input it
    drives and interpolated as that input's variability asks (linear for a continuous Real, else hold)."""
    shown = shown_source(shown_as, comp.source)
    table = read_csv_table(comp.fmu_path, shown)
    for conn in comp.connectors.values():
        if conn.name not in table.columns:
            raise ScenarioError(f"the input table {comp.source} has no column {conn.name!r} (its columns: "
                                f"{', '.join(table.columns)})", file=shown_as,
                                element=f"Connector {name}.{conn.name}", line=conn.line)
    out, columns = {}, []
    for vr, (column, driven) in enumerate(_driven_inputs(name, model, variables, shown_as).items()):
        if column not in table.columns:
            raise ScenarioError(f"the input table {comp.source} has no column {column!r}", file=shown_as,
                                element=f"Connection {name}.{column} -> {driven[0].qualified}")
        v = out[column] = _column_var(name, column, vr, driven, shown_as)
        if column in comp.connectors:
            _check_connector(comp.connectors[column], v, shown_as)
        values = column_values(table, column, v.type, shown)
        why = next((w for w in (value_error(v, x, allow_nonfinite=True) for x in values) if w), None)
        if why:
            raise ScenarioError(why, file=shown)
        columns.append(TableColumn(vr, values, linear=v.variability == "continuous"))
    return csv_source(table, columns), out


def _driven_inputs(name: str, model: SystemModel, variables: dict, shown_as: str) -> dict[str, list[Var]]:
    """Column -> the FMU variables the table's connections drive from it."""
    driven: dict[str, list[Var]] = {}
    for c in model.connections:
        if c.src_component != name:
            continue
        dst = variables.get(c.dst_component, {}).get(c.dst_connector)
        if dst is None:
            raise ScenarioError(f"component {c.dst_component!r} has no variable {c.dst_connector!r}", file=shown_as,
                                element=f"Connection {c.src} -> {c.dst}", line=c.line)
        driven.setdefault(c.src_connector, []).append(dst)
    return driven


def _column_var(name: str, column: str, vr: int, driven: list[Var], shown_as: str) -> Var:
    """A column as an output of the type of the inputs it drives; continuous when it drives a continuous Real
    (interpolated linearly), discrete otherwise (held). Inputs of other types or variabilities need columns of
    their own."""
    def how(v):
        return v.fmi_type, "continuous" if v.type == "Real" and v.variability == "continuous" else "discrete"
    first = driven[0]
    other = next((v for v in driven if how(v) != how(first)), None)
    if other is not None:
        raise ScenarioError(f"column {column!r} drives {first.qualified} ({' '.join(how(first))}) and "
                            f"{other.qualified} ({' '.join(how(other))}): give each its own column",
                            file=shown_as, element=f"Component {name}")
    return Var(name, column, vr, first.type, first.fmi_type, "output", how(first)[1], first.unit)


def _array_links(link: Link, variables, shown_as) -> list[Link]:
    """A connection between two whole arrays of one shape is one link per element; an element is a scalar."""
    src, dst = link.src, link.dst
    if not src.is_array and not dst.is_array:
        return [link]
    if src.shape != dst.shape or not (src.is_array and dst.is_array):
        shapes = " and ".join(f"{v.qualified} {list(v.shape) if v.is_array else 'a scalar'}" for v in (src, dst))
        raise ScenarioError(f"a connection joins two arrays of the same shape or two scalars (elements such as "
                            f"{dst.name}[1]); {shapes}", file=shown_as, element=f"Connection {src.qualified} -> "
                            f"{dst.qualified}", line=link.line)
    comp_src, comp_dst = variables[src.component], variables[dst.component]
    return [replace(link, src=comp_src[a], dst=comp_dst[b])
            for a, b in zip(element_names(src.name, src.shape), element_names(dst.name, dst.shape))]


def add_overrides(plan: Plan, params: dict[str, object] | None, allow_nonfinite: bool = False) -> None:
    """Values given on the command line (or the API), after those of the SSD so that they win; checks every
    value the plan sets."""
    for qualified, raw in (params or {}).items():
        comp, _, name = plan.split(qualified)
        v = plan.variables[comp][name]
        plan.params.append((v, parse_value(v, raw, qualified, allow_nonfinite), "command line"))
    plan.params[:] = _whole_arrays(plan.params, plan)
    for v, _, origin in plan.params:
        sized = (v.causality == "structuralParameter"
                 and _structural_sizes(plan.variables[v.component], plan.fmus[v.component]).get(v.name))
        if sized:
            raise ScenarioError(f"{v.qualified} is a structural parameter giving the size of {', '.join(sized)}; "
                                "changing it is not supported (arrays keep the sizes of the modelDescription)",
                                file=origin)
        if v.causality in ("output", "calculatedParameter", "local", "independent") and v.variability != "tunable":
            if v.causality != "local" or v.variability == "constant":
                raise ScenarioError(f"{v.qualified} has causality {v.causality} and cannot be given a value",
                                    file=origin)
        if v.variability == "constant":
            raise ScenarioError(f"{v.qualified} is a constant and cannot be given a value", file=origin)


def _whole_arrays(params: list, plan: Plan) -> list:
    """Values given to array elements, folded into one value of the whole array (FMI 3 sets an array as a
    whole): the modelDescription's start values with the elements given replaced, in the order given."""
    folded: dict[str, list] = {}
    out = []
    for v, value, origin in params:
        if v.index is None and not v.is_array:
            out.append((v, value, origin))
            continue
        whole = plan.variables[v.component][v.array or v.name]
        if whole.qualified not in folded:
            folded[whole.qualified] = list(whole.start)
            out.append((whole, folded[whole.qualified], origin))
        if v.is_array:
            folded[whole.qualified][:] = value
        else:
            folded[whole.qualified][v.index] = value
    return out


def shown_source(shown_as: str, source: str) -> str:
    """How a file of the scenario is named in messages: inside the archive or folder the user named, or beside
    a bare .ssd (not under the .ssd's own name)."""
    if not shown_as:
        return source
    if shown_as.lower().endswith(".ssd"):
        return str(Path(shown_as).parent / source)
    return f"{shown_as}/{source}"


def _line(origin: str):
    tail = origin.rsplit(":", 1)[-1]
    return int(tail) if tail.isdigit() else None


def _unit_table(model, fmus):
    table = {}
    for fmu in fmus.values():
        for u in getattr(fmu.md, "unitDefinitions", []) or []:
            table.setdefault(u.name, unit_from_fmu(u))
    table.update(model.units)   # the SSD's own definitions take precedence
    return table


def _link(c: Connection, model, variables, units, shown_as) -> Link:
    where = f"Connection {c.src} -> {c.dst}"
    src = variables.get(c.src_component, {}).get(c.src_connector)
    dst = variables.get(c.dst_component, {}).get(c.dst_connector)
    for end, v, comp, conn in (("start", src, c.src_component, c.src_connector),
                               ("end", dst, c.dst_component, c.dst_connector)):
        if comp not in variables:
            raise ScenarioError(f"unknown component {comp!r}", file=shown_as, element=where, line=c.line)
        if v is None:
            raise ScenarioError(f"component {comp!r} has no variable {conn!r}", file=shown_as, element=where,
                                line=c.line)
    if src.causality not in ("output", "calculatedParameter", "parameter"):
        raise ScenarioError(f"start {src.qualified} has causality {src.causality}; a connection must start at an "
                            "output", file=shown_as, element=where, line=c.line)
    if dst.causality not in ("input", "parameter"):
        raise ScenarioError(f"end {dst.qualified} has causality {dst.causality}; a connection must end at an input",
                            file=shown_as, element=where, line=c.line)
    why = _connection_type_error(src, dst)
    if why:
        raise ScenarioError(why, file=shown_as, element=where, line=c.line)
    link = Link(src, dst, line=c.line)
    ssd_src = model.components[c.src_component].connectors.get(c.src_connector)
    ssd_dst = model.components[c.dst_component].connectors.get(c.dst_connector)
    src_unit = (ssd_src.unit if ssd_src and ssd_src.unit else src.unit)
    dst_unit = (ssd_dst.unit if ssd_dst and ssd_dst.unit else dst.unit)
    if src.type == "Real" and not c.suppress_unit_conversion and src_unit and dst_unit and src_unit != dst_unit:
        conv = conversion(units.get(src_unit), units.get(dst_unit))
        if units.get(src_unit) is None or units.get(dst_unit) is None:
            conv = None
        if conv is None:
            raise ScenarioError(f"units {src_unit} and {dst_unit} are not convertible (set "
                                "suppressUnitConversion to connect them anyway)", file=shown_as, element=where,
                                line=c.line)
        link.factor, link.offset = conv
    t = c.transformation
    if t is not None and t.kind == "linear":
        if src.type != "Real":
            raise ScenarioError("a linear transformation needs Real connectors", file=shown_as, element=where,
                                line=c.line)
        link.offset = t.factor * link.offset + t.offset
        link.factor = t.factor * link.factor
    elif t is not None and t.kind == "map":
        conv = (lambda raw: parse_text(src.type, raw)) if src.type in (*INTEGER_BASES, "Boolean", "String") else None
        if conv is None:
            raise ScenarioError(f"a mapping transformation cannot map {src.fmi_type} values", file=shown_as,
                                element=where, line=c.line)
        try:
            link.mapping = {conv(k): conv(v) for k, v in t.mapping.items()}
        except ValueError:
            raise ScenarioError("mapping transformation entries do not match the connector type", file=shown_as,
                                element=where, line=c.line) from None
    return link


def _connection_type_error(src: Var, dst: Var) -> str | None:
    """Why a connection from ``src`` to ``dst`` cannot carry every value, or None. Integers connect when every
    value of the start's type fits the end's (a narrowing would cut values to their low bits) and both travel
    in the same buffer (Int8..Int32 and FMI 2.0 Integer in int32, UInt32 and Int64 in int64, UInt64 alone)."""
    mismatch = f"type mismatch: {src.qualified} is {src.fmi_type}, {dst.qualified} is {dst.fmi_type}"
    if src.type in INTEGER_BASES and dst.type in INTEGER_BASES:
        (lo, hi), (dlo, dhi) = _int_range(src), _int_range(dst)
        if not dlo <= lo <= hi <= dhi:
            return f"{mismatch}, and not every {src.fmi_type} value ({lo}..{hi}) fits {dst.fmi_type} ({dlo}..{dhi})"
        if src.type != dst.type:
            return (f"{mismatch}: the values would have to change width ({src.type} to {dst.type} buffers), "
                    "which connections do not do; connect variables of the same width")
        return None
    return mismatch if src.type != dst.type else None


_INTEGER_SSP = ("Integer", "Enumeration")
#: the SSP value types a variable of each base type takes
_COMPATIBLE = {"Real": ("Real",), "Integer": _INTEGER_SSP, "Int64": _INTEGER_SSP, "UInt64": _INTEGER_SSP,
               "Boolean": ("Boolean",), "String": ("String",), "Binary": ("Binary",)}


def _check_value(v: Var, value, ssp_type, origin, where):
    if v.type == "Integer" and v.fmi_type == "Enumeration" and ssp_type == "Enumeration":
        return value
    if ssp_type not in _COMPATIBLE.get(v.type, ()):
        raise ScenarioError(f"a {ssp_type} value cannot be given to {v.qualified} of type {v.fmi_type}",
                            file=origin.rsplit(":", 1)[0], element=where, line=_line(origin))
    return value


#: the values an FMI integer type holds (FMI 2.0 Integer and enumerations are 32-bit)
INT_RANGES = {"Integer": (-2**31, 2**31 - 1), "Enumeration": (-2**31, 2**31 - 1),
              "Int8": (-2**7, 2**7 - 1), "UInt8": (0, 2**8 - 1), "Int16": (-2**15, 2**15 - 1),
              "UInt16": (0, 2**16 - 1), "Int32": (-2**31, 2**31 - 1), "UInt32": (0, 2**32 - 1),
              "Int64": (-2**63, 2**63 - 1), "UInt64": (0, 2**64 - 1)}


def _int_range(v: Var) -> tuple[int, int]:
    return INT_RANGES.get(v.fmi_type, INT_RANGES["Integer"])


def value_error(v: Var, value, allow_nonfinite: bool = False) -> str | None:
    """Why ``value`` cannot be given to ``v`` (out of its integer type's range, not finite), or None.
    An out-of-range integer would be cut to its low bits by a binary FMU but kept whole by a Python one."""
    if v.type in INTEGER_BASES and not isinstance(value, bool) and isinstance(value, int):
        lo, hi = _int_range(v)
        if not lo <= value <= hi:
            return f"{value} is out of range for {v.qualified} ({v.fmi_type}: {lo}..{hi})"
    if v.type == "Real" and not allow_nonfinite and isinstance(value, float) and not math.isfinite(value):
        return (f"{value} is not a finite value for {v.qualified} (non-finite values are refused unless "
                "--allow-nonfinite is given)")
    return None


def parse_value(v: Var, raw, where: str, allow_nonfinite: bool = False):
    """A command-line (or API) value in the variable's type, checked for range and finiteness; an array's value
    is a sequence or a string of its elements separated by spaces or commas, row-major."""
    if v.is_array:
        return _parse_array(v, raw, where, allow_nonfinite)
    value = raw
    if isinstance(raw, str):
        try:
            value = parse_text(v.type, raw)      # Binary as FMI 3 writes its start values: hexadecimal digits
        except ValueError:
            raise ScenarioError(f"{raw!r} is not a valid {v.fmi_type} for {v.qualified}",
                                element=f"--param {where}") from None
    elif v.type == "Real" and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    why = value_error(v, value, allow_nonfinite)
    if why:
        raise ScenarioError(why, element=f"--param {where}")
    return value


def _parse_array(v: Var, raw, where: str, allow_nonfinite: bool) -> list:
    items = raw.replace(",", " ").split() if isinstance(raw, str) else list(raw)
    size = int(math.prod(v.shape))
    if len(items) != size:
        raise ScenarioError(f"{v.qualified} has {size} elements (shape {list(v.shape)}), {len(items)} were given",
                            element=f"--param {where}")
    element = replace(v, shape=(), index=None)
    return [parse_value(element, x, where, allow_nonfinite) for x in items]
