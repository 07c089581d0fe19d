"""Checking a parsed system against its FMUs and resolving it to value references, before anything runs.

Every mismatch between the SSD and an FMU's modelDescription (unknown connector, type, causality,
unit dimension) is reported here, so that no FMU is instantiated for a scenario that cannot run.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import ScenarioError
from ..fmi.cache import LoadedFmu, load_fmu
from ..fmi.factory import choose_kind
from ..fmi.slave import INTEGER_BASES
from ..ssp.model import CSV_SOURCE_TYPE, Component, Connection, SystemModel
from ..units import conversion, unit_from_fmu
from ..values import parse_text
from .checks import check_connector, connection_type_error
from .input_tables import add_input_file, csv_component
from .model import Link, Plan, Var, element_names, shown_source
from .parameters import add_overrides, add_parameters
from .reuse import keep_plan, kept_structure, plan_key
from .variables import component_variables, element_feedthrough


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
    key, loaded = plan_key(model, shown_as, lenient, implementation, inputs)
    known = kept_structure(key)
    if known is None:
        fmus, variables, feed, units, links = _plan_structure(model, shown_as, lenient, implementation, inputs)
        if key is not None:
            keep_plan(key, fmus, variables, feed, units, links)
    else:
        fmus, variables, feed, units, links = known.for_run(model, loaded)
    plan = Plan(model, shown_as, fmus, links, [], feed, variables)
    add_parameters(plan, model, units, allow_nonfinite, lenient)
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
        add_input_file(model, Path(inputs), variables, shown_as, lenient)
    # input tables last: their columns take the types of the FMU inputs they drive
    for name, comp in model.components.items():
        if comp.type == CSV_SOURCE_TYPE:
            fmus[name], variables[name] = csv_component(name, comp, model, variables, shown_as)
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


def _fmu_component(name: str, comp: Component, implementation: str, shown_as: str, lenient: bool):
    """An FMU component's loaded FMU (with the kind it runs as), variables and output dependencies, its SSD
    connectors checked against them."""
    where = f"Component {name}"
    fmu = load_fmu(comp.fmu_path, shown_source(shown_as, comp.source), lenient=lenient)
    try:
        kind = choose_kind(fmu, implementation)
    except ValueError as exc:
        raise ScenarioError(str(exc), file=shown_as, element=where, line=comp.line) from None
    variables = component_variables(name, fmu)
    for conn in comp.connectors.values():
        v = variables.get(conn.name)
        if v is None:
            raise ScenarioError(f"the FMU {comp.source} has no variable {conn.name!r}", file=shown_as,
                                element=f"Connector {name}.{conn.name}", line=conn.line)
        check_connector(conn, v, shown_as)
    outs = {}
    for u in fmu.md.outputs:
        deps = u.dependencies   # None: the FMU did not say, so it may depend on every input
        outs[u.variable.name] = None if deps is None else {d.name for d in deps if d.causality == "input"}
    return fmu.as_kind(kind), variables, element_feedthrough(variables, outs)


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
    return [link.between(comp_src[a], comp_dst[b])
            for a, b in zip(element_names(src.name, src.shape), element_names(dst.name, dst.shape))]


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
    why = connection_type_error(src, dst)
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
