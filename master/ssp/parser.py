"""SystemStructure.ssd (plus .ssv and .ssm files) to a flattened SystemModel.

Elements are matched by local name so that SSP 1.0 and SSP 2.0 documents read alike;
XSD validation is applied where a schema exists (SSP 1.x).
"""
from __future__ import annotations

import copy
import hashlib
import os
from pathlib import Path
from types import MappingProxyType
from typing import NamedTuple
from urllib.parse import unquote, urlparse

from lxml import etree

from ..errors import ScenarioError
from ..records import replaced
from . import xsd
from .archive import MemoryArchive, schema_checked
from .connection_extrapolation import read_connection_order
from .model import (CSV_SOURCE_TYPE, SSP_TYPES, Component, Connection, Connector, ParameterValue,
                    SystemModel, Transformation)
from .settings_annotations import read_master_settings
from ..units import BASE_UNITS, Unit
from ..values import parse_boolean, parse_text

FMU_TYPES = ("application/x-fmu-sharedlibrary",)


_LOCAL: dict[str, str] = {}      # "{namespace}name" -> "name": an SSD repeats a few dozen tags thousands of times


def _local(el) -> str:
    tag = el.tag
    if not isinstance(tag, str):
        return ""
    name = _LOCAL.get(tag)
    if name is None:
        name = _LOCAL[tag] = etree.QName(tag).localname
    return name


def _children(el, name):
    return [c for c in el if _local(c) == name]


def _child(el, name):
    for c in el:
        if _local(c) == name:
            return c
    return None


def _float(el, attr, default, shown_as):
    raw = el.get(attr)
    if raw is None:
        return default
    try:
        return float(raw)
    except ValueError:
        raise ScenarioError(f"attribute {attr}={raw!r} is not a number", file=shown_as,
                            element=_local(el), line=el.sourceline) from None


def _bool(raw: str | None) -> bool:
    """An optional xs:boolean attribute: absent or not true is false."""
    try:
        return raw is not None and parse_boolean(raw)
    except ValueError:
        return False


def _declared(name: str, connectors: dict) -> bool:
    """A connector of the SSD, or an element of one: ``y[2]`` of the array connector ``y`` (FMI 3.0 arrays)."""
    return name in connectors or (name.endswith("]") and name.split("[", 1)[0] in connectors)


class _Reader:
    def __init__(self, ssd_path: Path, root: Path, shown_root: str, members: dict | None = None):
        self.ssd_path = ssd_path
        self.root = root
        self.shown_root = shown_root
        self.members = members                # archive read from memory: member name -> its file (else None)
        self.member_paths = set(members.values()) if members is not None else set()
        self.member_files: dict[tuple, Path] = {}     # (source, folder) -> the member's file, as resolved
        self.units: dict[str, Unit] = {}
        self.components: dict[str, Component] = {}
        self.edges: list[tuple] = []          # (src node, dst node, Connection template)
        self.outgoing: dict[tuple, list] = {}  # node -> [(next node, Connection template)] (flatten_connections)
        self.system_connectors: set = set()   # nodes that are connectors of (sub)systems
        self.parameters: list[ParameterValue] = []
        self.ignored: list[tuple[str, str]] = []    # (parameter file, name): values that name nothing (SSP: ignored)
        self.annotations: dict[str, object] = {}
        self.reuse_values = False             # parameter sets read before are not parsed again (_PARAMETER_SETS)

    def shown(self, path: Path) -> str:
        try:
            rel = path.relative_to(self.root)
        except ValueError:
            return str(path)
        return f"{self.shown_root}/{rel.as_posix()}" if self.shown_root else rel.as_posix()

    # -- units ---------------------------------------------------------------------------
    def read_units(self, units_el, shown_as):
        if units_el is None:
            return
        for u in _children(units_el, "Unit"):
            base = _child(u, "BaseUnit")
            if base is None:
                self.units[u.get("name")] = Unit(u.get("name"))
                continue
            exps = tuple(int(base.get(b, "0")) for b in BASE_UNITS)
            self.units[u.get("name")] = Unit(u.get("name"), _float(base, "factor", 1.0, shown_as),
                                             _float(base, "offset", 0.0, shown_as), exps)

    # -- connectors ----------------------------------------------------------------------
    def read_connectors(self, el, shown_as) -> dict[str, Connector]:
        out: dict[str, Connector] = {}
        conns = _child(el, "Connectors")
        if conns is None:
            return out
        for c in _children(conns, "Connector"):
            typ, unit = None, None
            for t in c:
                if _local(t) in SSP_TYPES:
                    typ = _local(t)
                    unit = t.get("unit")
            name = c.get("name")
            if name in out:
                raise ScenarioError(f"duplicate connector {name!r}", file=shown_as,
                                    element=f"Connector {name}", line=c.sourceline)
            out[name] = Connector(name, c.get("kind"), typ, unit, c.sourceline)
        return out

    # -- systems -------------------------------------------------------------------------
    def read_system(self, sys_el, prefix: str, shown_as: str, ssd_dir: Path, known: dict | None = None):
        """``known``: the components of this very structure, read before (``_Structure``): only what a run may
        change is read again (where the FMUs are, the parameter values, the annotations), in the same order."""
        if known is None:
            for name in self.read_connectors(sys_el, shown_as):
                self.system_connectors.add((prefix.rstrip("."), name))
        ann = _child(sys_el, "Annotations")     # before the subsystems': an enclosing system's annotation wins
        if ann is not None:
            for a in _children(ann, "Annotation"):
                self.annotations.setdefault(a.get("type"), a)
        elements = _child(sys_el, "Elements")
        names = set()
        if elements is not None:
            for el in elements:
                kind = _local(el)
                if kind not in ("Component", "System"):
                    continue
                name = el.get("name")
                if name in names:
                    raise ScenarioError(f"duplicate element name {name!r}", file=shown_as,
                                        element=f"{kind} {name}", line=el.sourceline)
                names.add(name)
                path = f"{prefix}{name}"
                if kind == "System":
                    self.read_system(el, path + ".", shown_as, ssd_dir, known)    # with its own bindings
                elif known is not None:
                    self.place_component(el, known[path], shown_as, ssd_dir)
                else:
                    self.read_component(el, path, shown_as, ssd_dir)
        self.read_bindings(sys_el, prefix, shown_as, ssd_dir, is_component=False)
        conns = _child(sys_el, "Connections")
        if conns is not None and known is None:
            for c in _children(conns, "Connection"):
                self.read_connection(c, prefix, names, shown_as)

    def read_component(self, el, path, shown_as, ssd_dir):
        ctype = el.get("type", "application/x-fmu-sharedlibrary")
        source = el.get("source")
        where = f"Component {path}"
        if ctype not in (*FMU_TYPES, CSV_SOURCE_TYPE):
            raise ScenarioError(f"component type {ctype!r} is not supported (FMUs: {FMU_TYPES[0]}; input tables: "
                                f"{CSV_SOURCE_TYPE})", file=shown_as, element=where, line=el.sourceline)
        if not source:
            raise ScenarioError("component has no source", file=shown_as, element=where, line=el.sourceline)
        fmu_path = self.component_file(source, ctype, where, el, shown_as, ssd_dir)
        comp = Component(path, source, fmu_path, ctype, self.read_connectors(el, shown_as), el.sourceline,
                         el.get("implementation", "any"))
        self.components[path] = comp
        self.read_bindings(el, path, shown_as, ssd_dir, is_component=True)

    def place_component(self, el, known: Component, shown_as, ssd_dir):
        """A component of a structure read before: the run's own copy, with its file where this run has it."""
        fmu_path = self.component_file(known.source, known.type, f"Component {known.name}", el, shown_as, ssd_dir)
        self.components[known.name] = replaced(known, fmu_path=fmu_path)
        self.read_bindings(el, known.name, shown_as, ssd_dir, is_component=True)

    def component_file(self, source, ctype, where, el, shown_as, ssd_dir) -> Path:
        if self.members is not None:     # a fleet's components share a few members, each a file of the store
            found = self.member_files.get((source, ssd_dir))
            if found is None:
                found = self.member_files[(source, ssd_dir)] = self.resolve_source(source, ssd_dir)
            if found in self.member_paths:
                return found
        fmu_path = self.resolve_source(source, ssd_dir)
        if not fmu_path.is_file():
            what = "input table" if ctype == CSV_SOURCE_TYPE else "FMU"
            raise ScenarioError(f"{what} {source!r} not found in the scenario", file=shown_as, element=where,
                                line=el.sourceline)
        return fmu_path

    def resolve_source(self, source: str, base_dir: Path) -> Path:
        parsed = urlparse(source)
        if parsed.scheme == "file":
            return Path(unquote(parsed.path))
        if parsed.scheme and len(parsed.scheme) > 1:
            raise ScenarioError(f"source URI scheme {parsed.scheme!r} is not supported", file=self.shown(self.ssd_path))
        rel = unquote(source)
        candidate = (base_dir / rel)
        if self.members is not None:
            return self.member_file(candidate, rel)
        if not candidate.exists() and (self.root / rel).exists():
            candidate = self.root / rel
        return candidate

    def member_file(self, candidate: Path, rel: str) -> Path:
        """Where an archive read from memory has the file that unpacking it would have put at ``candidate`` (or
        else at ``root/rel``); a member it does not hold stays at ``candidate``, where no file is."""
        for place in (candidate, self.root / rel):
            name = self.member_name(place)
            if name in self.members:
                return self.members[name]
        return candidate

    def member_name(self, place: Path) -> str | None:
        try:
            rel = place.relative_to(self.root)
        except ValueError:
            return None
        return os.path.normpath(rel.as_posix())

    def read_connection(self, c, prefix, names, shown_as):
        # SSP 1.0 5.3.5 / 2.0 5.3.6: without startElement (endElement) the connector is one of this system; some
        # tools (OMSimulator) write the attribute empty for that
        start_el, end_el = c.get("startElement") or None, c.get("endElement") or None
        for e in (start_el, end_el):
            if e is not None and e not in names:
                raise ScenarioError(f"connection refers to unknown element {e!r}", file=shown_as,
                                    element=f"Connection {start_el or ''}.{c.get('startConnector')} -> "
                                            f"{end_el or ''}.{c.get('endConnector')}", line=c.sourceline)
        src = (f"{prefix}{start_el}" if start_el else prefix, c.get("startConnector"))
        dst = (f"{prefix}{end_el}" if end_el else prefix, c.get("endConnector"))
        trans = None
        for t in c:
            kind = _local(t)
            if kind == "LinearTransformation":
                trans = Transformation("linear", _float(t, "factor", 1.0, shown_as), _float(t, "offset", 0.0, shown_as))
            elif kind in ("BooleanMappingTransformation", "IntegerMappingTransformation",
                          "EnumerationMappingTransformation"):
                mapping = {}
                for m in _children(t, "MapEntry"):
                    mapping[m.get("source")] = m.get("target")
                trans = Transformation("map", mapping=mapping)
        conn = Connection(src[0].rstrip("."), src[1], dst[0].rstrip("."), dst[1], trans,
                          _bool(c.get("suppressUnitConversion")), c.sourceline)
        conn.extrapolation = read_connection_order(c, shown_as, f"Connection {conn.src} -> {conn.dst}")
        self.edges.append((src, dst, conn, shown_as))

    # -- parameters ----------------------------------------------------------------------
    def read_bindings(self, el, path, shown_as, ssd_dir, is_component):
        pbs = _child(el, "ParameterBindings")
        if pbs is None:
            return
        to_connectors: list[ParameterValue] = []
        for pb in _children(pbs, "ParameterBinding"):
            ptype = pb.get("type", "application/x-ssp-parameter-set")
            if ptype != "application/x-ssp-parameter-set":
                raise ScenarioError(f"parameter binding type {ptype!r} is not supported", file=shown_as,
                                    element=f"ParameterBinding of {path or 'system'}", line=pb.sourceline)
            prefix = pb.get("prefix", "") or ""
            source = pb.get("source")
            if source:
                ssv = self.resolve_source(source, ssd_dir)
                if not ssv.is_file():
                    raise ScenarioError(f"parameter file {source!r} not found", file=shown_as,
                                        element=f"ParameterBinding of {path or 'system'}", line=pb.sourceline)
                ssv_shown = self.shown(ssv)
                tree = xsd.parse_xml(ssv, ssv_shown)
                xsd.validate(tree, "ssv", ssv_shown)
                pset, pset_shown = tree.getroot(), ssv_shown
            else:
                values = _child(pb, "ParameterValues")
                pset = _child(values, "ParameterSet") if values is not None else None
                pset_shown = shown_as
                if pset is None:
                    raise ScenarioError("parameter binding has neither source nor inline values", file=shown_as,
                                        element=f"ParameterBinding of {path or 'system'}", line=pb.sourceline)
            mapping = self.read_mapping(pb, shown_as, ssd_dir)
            self.read_units(_child(pset, "Units"), pset_shown)
            if mapping is None and is_component and self.reuse_values:
                key = (path, prefix, pset.sourceline, etree.tostring(pset))
                read = _PARAMETER_SETS.get(key)
                if read is None:
                    read = _keep_parameters(key, tuple(self.read_parameters(pset, path, prefix, None, True,
                                                                            pset_shown)))
            else:
                read = self.read_parameters(pset, path, prefix, mapping, is_component, pset_shown)
            for comp, var, typ, value, line, unit in read:
                if comp is None:                         # names nothing: ignored (warned about by the plan)
                    self.ignored.append((pset_shown, var))
                    continue
                pv = ParameterValue(comp, var, typ, value, f"{pset_shown}:{line}")
                pv.unit = unit
                if isinstance(comp, tuple):             # a connector of a (sub)system: see connector_values
                    pv.component, pv.via = comp[0], comp
                    to_connectors.append(pv)
                else:
                    self.parameters.append(pv)
        # a system connector's value reaches the component connectors it is connected to after the direct values
        # of the same system (so `k_cref` -> `addP.k1` wins over `addP.k1` in one set, as in OMSimulator), and
        # before those of enclosing systems, which take precedence (SSP 1.0 5.3.3)
        self.parameters.extend(to_connectors)

    def read_parameters(self, pset, path, prefix, mapping, is_component, pset_shown):
        """(component, variable, type, value, source line, unit) of each parameter of the set."""
        params = _child(pset, "Parameters")
        for p in (_children(params, "Parameter") if params is not None else []):
            name = prefix + p.get("name")
            value_el = next((t for t in p if _local(t) in SSP_TYPES), None)
            if value_el is None:
                continue
            typ = _local(value_el)
            raw = value_el.get("value")
            if typ == "Enumeration":
                raw = value_el.get("value")
            given = self.convert_value(typ, raw, pset_shown, p)
            unit = value_el.get("unit")
            # a mapped name goes to each target the mapping gives it (one source may feed several parameters)
            for target, trans in (mapping.get(name) if mapping is not None else None) or ((name, None),):
                value = given
                if trans is not None and trans.kind == "linear" and typ == "Real":
                    value = trans.factor * value + trans.offset
                elif trans is not None and trans.kind == "map":
                    value = self.convert_value(typ, trans.mapping.get(raw, raw), pset_shown, p)
                comp, var = self.resolve_parameter_target(path, target, is_component, pset_shown, p)
                yield comp, var, typ, value, p.sourceline, unit

    def read_mapping(self, pb, shown_as, ssd_dir):
        pm = _child(pb, "ParameterMapping")
        if pm is None:
            return None
        source = pm.get("source")
        if source:
            ssm = self.resolve_source(source, ssd_dir)
            if not ssm.is_file():
                raise ScenarioError(f"parameter mapping {source!r} not found", file=shown_as,
                                    element="ParameterMapping", line=pm.sourceline)
            ssm_shown = self.shown(ssm)
            tree = xsd.parse_xml(ssm, ssm_shown)
            xsd.validate(tree, "ssm", ssm_shown)
            root = tree.getroot()
        else:
            root = _child(pm, "ParameterMapping")
            if root is None:
                return None
        out = {}
        for entry in _children(root, "MappingEntry"):
            trans = None
            for t in entry:
                if _local(t) == "LinearTransformation":
                    trans = Transformation("linear", _float(t, "factor", 1.0, shown_as), _float(t, "offset", 0.0, shown_as))
                elif _local(t).endswith("MappingTransformation"):
                    trans = Transformation("map", mapping={m.get("source"): m.get("target")
                                                           for m in _children(t, "MapEntry")})
            out.setdefault(entry.get("source"), []).append((entry.get("target"), trans))
        return out

    @staticmethod
    def convert_value(typ, raw, shown_as, el):
        try:
            return parse_text(typ if typ != "Enumeration" else "String", raw)   # ssv:Binary is xs:hexBinary
        except (TypeError, ValueError):
            raise ScenarioError(f"value {raw!r} is not a valid {typ}", file=shown_as,
                                element=f"Parameter {el.get('name')}", line=el.sourceline) from None

    def resolve_parameter_target(self, path, name, is_component, shown_as, el):
        """Map a parameter name to (component, variable): bare names at a component, hierarchical names at a
        system (SSP 1.0 5.3.3): a connector of the system or of a subsystem, ``((system, connector), name)``,
        or a component's variable by the longest component path that prefixes the name; ``(None, name)`` when
        it names neither (the standard ignores such values)."""
        if is_component:
            return path, name
        full = f"{path}{name}"
        owner, _, connector = full.rpartition(".")
        if (owner, connector) in self.system_connectors:
            return (owner, connector), connector
        best = None
        for comp in self.components:
            if full.startswith(comp + ".") and (best is None or len(comp) > len(best)):
                best = comp
        if best is None:
            return None, full
        return best, full[len(best) + 1:]

    def connector_values(self, reach: dict) -> list[ParameterValue]:
        """The parameters with each value given to a system connector replaced by the values it gives the
        component connectors it is connected to (``reach``: system connector -> (component, connector,
        transformation) at the ends of the connections from it, through further system connectors); a system
        connector connected to no component keeps its value to itself (it reaches no FMU)."""
        out = []
        for pv in self.parameters:
            via = getattr(pv, "via", None)
            if via is None:
                out.append(pv)
                continue
            for comp, connector, trans in reach.get(via, ()):
                value = pv.value
                if trans is not None and trans.kind == "linear" and pv.type == "Real":
                    value = trans.factor * value + trans.offset
                elif trans is not None and trans.kind == "map":
                    value = parse_text(pv.type if pv.type != "Enumeration" else "String",
                                       trans.mapping.get(str(value), str(value)))
                given = ParameterValue(comp, connector, pv.type, value, pv.origin)
                given.unit = getattr(pv, "unit", None)
                out.append(given)
        return out

    # -- flattening ----------------------------------------------------------------------
    def flatten_connections(self) -> list[Connection]:
        """Follow connections through system connectors so that every connection joins two FMU connectors."""
        outgoing: dict[tuple, list] = {}
        for src, dst, conn, shown_as in self.edges:
            for node in (src, dst):
                owner, name = node
                owner = owner.rstrip(".")
                if owner in self.components:
                    if not _declared(name, self.components[owner].connectors) and self.components[owner].connectors:
                        raise ScenarioError(f"component {owner!r} has no connector {name!r} in the SSD",
                                            file=shown_as, element=f"Connection {conn.src} -> {conn.dst}",
                                            line=conn.line)
                elif (owner, name) not in self.system_connectors:
                    raise ScenarioError(f"connector {name!r} of {owner or 'the top system'} is not declared",
                                        file=shown_as, element=f"Connection {conn.src} -> {conn.dst}", line=conn.line)
            outgoing.setdefault(self._key(src), []).append((self._key(dst), conn))
        self.outgoing = outgoing
        flat, found, walked = [], set(), set()
        for src, dst, conn, _ in self.edges:
            skey = self._key(src)
            if skey[0] not in self.components or skey in walked:
                continue
            walked.add(skey)
            self._walk(skey, skey, None, False, outgoing, flat, found, set(), None)
        return flat

    def connector_reach(self) -> dict:
        """System connector -> ((component, connector, transformation), ...) it drives through connections
        (after ``flatten_connections``), for the values given to system connectors."""
        reach = {}
        for node in sorted(self.system_connectors):
            flat: list[Connection] = []
            self._walk(node, node, None, False, self.outgoing, flat, set(), set(), None)
            if flat:
                reach[node] = tuple((c.dst_component, c.dst_connector, c.transformation) for c in flat)
        return reach

    @staticmethod
    def _key(node):
        return (node[0].rstrip("."), node[1])

    def _walk(self, origin, node, trans, suppress, outgoing, flat, found, seen, order):
        """Depth-first from a component output through system connectors to component inputs."""
        if node in seen:
            return
        seen = seen | {node}
        for nxt, conn in outgoing.get(node, []):
            t = _compose(trans, conn.transformation)
            sup = suppress or conn.suppress_unit_conversion
            k = order if order is not None else conn.extrapolation      # the first annotated piece of the path
            if nxt[0] in self.components:
                if (origin, nxt) not in found:
                    found.add((origin, nxt))
                    flat.append(Connection(origin[0], origin[1], nxt[0], nxt[1], t, sup, conn.line, k))
            else:
                self._walk(origin, nxt, t, sup, outgoing, flat, found, seen, k)


def _compose(first: Transformation | None, second: Transformation | None) -> Transformation | None:
    if first is None:
        return second
    if second is None:
        return first
    if first.kind == second.kind == "linear":
        return Transformation("linear", second.factor * first.factor, second.factor * first.offset + second.offset)
    if first.kind == second.kind == "map":
        return Transformation("map", mapping={k: second.mapping.get(v, v) for k, v in first.mapping.items()})
    raise ScenarioError("cannot chain a linear and a mapping transformation through a system connector")


class _Structure(NamedTuple):
    """What an SSD's structure key determines: read once, shared by every run of that structure (never modified:
    a run gets copies of the components and connections, and the connectors as read-only mappings).  A named
    tuple, immutable as the frozen dataclass it was (``master.records`` says why it is not a dataclass)."""
    units: dict                 # the SSD's top-level units (a parameter set may add its own)
    components: dict            # name -> Component, fmu_path as the first run found it
    connections: tuple
    size: int                   # connectors and connections: what bounds the cache
    system_connectors: frozenset = None      # (system, connector) of every (sub)system
    reach: MappingProxyType = None    # Reader.connector_reach, read-only


# structure key -> _Structure: a campaign worker reads the same system with other parameter values run after run
_STRUCTURES: dict[str, _Structure] = {}
_MAX_STRUCTURES = 32
_MAX_KEPT_SIZE = 100_000        # connectors and connections of all kept structures (4 UAVs: ~700; 256: ~45 000)
#: top-level parts of an SSD that a run reads again (run settings, plugin data), not part of its structure
_RUN_PARTS = ("DefaultExperiment", "Annotations")


def structure_key(top) -> str:
    """The SHA-256 of everything in the SSD but its values: inline ParameterValues (the parameter files' contents
    are read per run anyway), the DefaultExperiment and the top-level annotations.  The source lines of what the
    values were are part of it, since the components and connections read keep their lines for messages."""
    h = hashlib.sha256(repr((top.tag, sorted(top.attrib.items()), top.sourceline)).encode())
    for child in top:
        if _local(child) in _RUN_PARTS:
            h.update(b"\0run part\0")
            continue
        taken = [(pv.getparent(), pv) for pv in child.iter("{*}ParameterValues")]
        lines, places = [], []
        for parent, pv in taken:
            after = _following(pv)
            lines.append((pv.sourceline, after.sourceline if after is not None else None))
            places.append(parent.index(pv))
            parent.remove(pv)           # with its tail: the lines it spanned are in ``lines``
        try:
            h.update(repr((child.sourceline, lines)).encode())
            h.update(etree.tostring(child))
        finally:
            for (parent, pv), index in zip(reversed(taken), reversed(places)):
                parent.insert(index, pv)
    return h.hexdigest()


# the writer's number of an SSD shape (archive.MemoryArchive.shape) -> the structure key of its SSDs
_SHAPE_KEYS: dict[int, str] = {}


def _structure_key(top, memory: MemoryArchive | None) -> str:
    """:func:`structure_key`, computed once per shape of the SSDs this process wrote."""
    shape = memory.shape if memory is not None else None
    key = _SHAPE_KEYS.get(shape) if shape is not None else None
    if key is None:
        key = structure_key(top)
        if shape is not None:
            if len(_SHAPE_KEYS) >= _MAX_STRUCTURES:
                _SHAPE_KEYS.clear()
            _SHAPE_KEYS[shape] = key
    return key


def _following(el):
    """The next element after ``el`` and everything in it, in document order (None at the end)."""
    while el is not None:
        nxt = el.getnext()
        if nxt is not None:
            return nxt
        el = el.getparent()
    return None


# (component, prefix, source line, the ParameterSet element's bytes) -> what read_parameters read from it: most
# parameter sets of a campaign's runs are the same from run to run (the values are immutable: numbers, strings)
_PARAMETER_SETS: dict[tuple, tuple] = {}
_MAX_PARAMETER_SETS = 512
_MAX_PARAMETER_BYTES = 16 << 20     # of the kept sets' XML
_parameter_bytes = [0]


def _keep_parameters(key: tuple, read: tuple) -> tuple:
    if len(_PARAMETER_SETS) >= _MAX_PARAMETER_SETS or _parameter_bytes[0] + len(key[3]) > _MAX_PARAMETER_BYTES:
        _PARAMETER_SETS.clear()     # emptied when full, as the other caches of a worker
        _parameter_bytes[0] = 0
    if len(key[3]) <= _MAX_PARAMETER_BYTES:
        _PARAMETER_SETS[key] = read
        _parameter_bytes[0] += len(key[3])
    return read


def _size(components: dict, connections) -> int:
    return sum(len(c.connectors) for c in components.values()) + len(connections)


def _keep_structure(key: str, known: _Structure) -> _Structure:
    """``known`` kept under ``key`` unless it alone is over the bound; the cache emptied when full."""
    if len(_STRUCTURES) >= _MAX_STRUCTURES or sum(s.size for s in _STRUCTURES.values()) + known.size > _MAX_KEPT_SIZE:
        _STRUCTURES.clear()
    if known.size <= _MAX_KEPT_SIZE:
        _STRUCTURES[key] = known
    return known


def _frozen(components: dict) -> dict:
    return {name: replaced(c, connectors=MappingProxyType(dict(c.connectors))) for name, c in components.items()}


def read_ssd(ssd_path: Path, root: Path, shown_root: str = "", validate: bool = True,
             reuse_structure: bool = False, memory: MemoryArchive | None = None) -> SystemModel:
    """Read and validate an SSD; ``shown_root`` is how the scenario is named in messages.  ``reuse_structure``:
    an SSD whose structure (:func:`structure_key`) this process has read before reads only its values again, and
    the model says its key (``SystemModel.structure``) for the plan to reuse its part too.  ``memory``: the
    archive as this process wrote it (``archive.open_scenario(in_memory=True)``): the SSD is parsed from its bytes
    and the FMUs are found in its members, named as though the archive were unpacked at ``root``."""
    ssd_path = Path(ssd_path)
    reader = _Reader(ssd_path, Path(root), shown_root, memory.members if memory is not None else None)
    shown_as = reader.shown(ssd_path)
    source = memory.ssd if memory is not None else xsd.read_bytes(ssd_path, shown_as)
    tree = xsd.parse_xml(ssd_path, shown_as, source)
    top = tree.getroot()
    if _local(top) != "SystemStructureDescription":
        raise ScenarioError(f"root element is {_local(top)!r}, expected ssd:SystemStructureDescription",
                            file=shown_as, line=top.sourceline)
    checked = memory.validated if memory is not None else schema_checked(ssd_path)
    if validate and not checked:
        xsd.validate(tree, "ssd", shown_as, source=source)
    reader.reuse_values = reuse_structure
    key = _structure_key(top, memory) if reuse_structure else None
    known = _STRUCTURES.get(key) if key is not None else None
    if known is not None:
        reader.units = {name: copy.copy(u) for name, u in known.units.items()}
        reader.system_connectors = set(known.system_connectors)
    else:
        reader.read_units(_child(top, "Units"), shown_as)
    top_units = {name: copy.copy(u) for name, u in reader.units.items()}    # the cache's own
    system = _child(top, "System")
    if system is None:
        raise ScenarioError("no ssd:System element", file=shown_as)
    reader.read_system(system, "", shown_as, ssd_path.parent, known.components if known is not None else None)
    top_ann = _child(top, "Annotations")
    if top_ann is not None:
        for a in _children(top_ann, "Annotation"):
            reader.annotations.setdefault(a.get("type"), a)
    model = SystemModel(top.get("name", system.get("name", "system")), ssd_path, Path(root),
                        top.get("version", "1.0"))
    if known is None:
        connections = reader.flatten_connections()
        reach = reader.connector_reach()
        if key is not None and reader.components:
            known = _keep_structure(key, _Structure(top_units, _frozen(reader.components), tuple(connections),
                                                    _size(reader.components, connections),
                                                    frozenset(reader.system_connectors), MappingProxyType(reach)))
            reader.components = {name: copy.copy(c) for name, c in known.components.items()}
    if known is not None:
        connections = [replaced(c) for c in known.connections]
        reach = known.reach
    model.structure = key
    model.components = reader.components
    model.connections = connections
    model.parameters = reader.connector_values(reach)
    model.ignored_parameters = reader.ignored
    model.units = reader.units
    model.annotations = reader.annotations
    exp = _child(top, "DefaultExperiment")
    if exp is not None:
        model.start_time = _float(exp, "startTime", None, shown_as)
        model.stop_time = _float(exp, "stopTime", None, shown_as)
        ann = _child(exp, "Annotations")
        if ann is not None:
            for a in _children(ann, "Annotation"):
                reader.annotations.setdefault(a.get("type"), a)
    model.settings = read_master_settings(model.annotations, shown_as)
    if not model.components:
        raise ScenarioError("the system has no FMU components", file=shown_as)
    return model
