"""Writing SSP 1.0 archives that validate against the official schema and run in other masters.

The step size is written in our own settings annotation and also in the OSP and OMSimulator
annotations, so libcosim and OMSimulator pick the same step without extra options.
"""
from __future__ import annotations

import copy
import glob
import hashlib
import io
import itertools
import os
import re
import shutil
import struct
import threading
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from . import xsd
from .archive import remember_written
from .connection_extrapolation import write_connection_order
from .settings_annotations import OUR_NS, OUR_TYPE

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
    "cm": OUR_NS,
}


def _q(prefix, name):
    return f"{{{NS[prefix]}}}{name}"


def _fmt(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, bytes):
        return v.hex()          # ssv:Binary values are xs:hexBinary
    return str(v)


@dataclass
class _Comp:
    name: str
    fmu: Path
    connectors: list           # (name, kind, type, unit)
    params: dict               # var -> (type, value)
    ssv: str | None = None     # put parameters in resources/<name>.ssv instead of inline


# (id of a model description, the parameters set) -> (the description, kept alive for its id; its connectors):
# a campaign worker writes the same FMUs with the same parameter names into every run's SSD, and going through
# a strategy FMU's thousand variables for its few dozen connectors cost more than the rest of its component
_CONNECTORS: dict[tuple, tuple[object, tuple]] = {}
_MAX_CONNECTORS = 256


def _described_connectors(md, params: dict) -> tuple:
    """(name, kind, type, unit) of every input and output of the FMU, and of the parameters in ``params``."""
    key = (id(md), frozenset(params))
    hit = _CONNECTORS.get(key)
    if hit is not None and hit[0] is md:
        return hit[1]
    connectors = []
    for v in md.modelVariables:
        if v.type == "Clock":       # SSP 1.0 has no clock connector type; the clocked variables themselves stay
            continue
        if v.causality in ("input", "output") or (v.causality == "parameter" and v.name in params):
            t = {"Float64": "Real", "Float32": "Real"}.get(v.type, v.type)
            if t.startswith(("Int", "UInt")):
                t = "Integer"
            connectors.append((v.name, v.causality, t, getattr(v, "unit", None)))
    return _keep(_CONNECTORS, key, (md, tuple(connectors)))[1]


# (FMU file, its identity and times) -> its model description: a fleet's builder adds the same few FMUs dozens of
# times, and the FMU cache's own look-up resolves the path each time
_DESCRIPTIONS: dict[tuple, object] = {}


def _description(fmu_path: Path):
    from ..fmi.cache import load_fmu       # unpacked and read once per process and FMU content
    try:
        st = fmu_path.stat()
    except OSError:
        return load_fmu(fmu_path).md       # says why
    key = (str(fmu_path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    md = _DESCRIPTIONS.get(key)
    if md is None:
        md = _keep(_DESCRIPTIONS, key, load_fmu(fmu_path).md)
    return md


def _keep_tree(key: tuple, tree, slots: list, size: int) -> int | None:
    """Keep the tree; returns the number that names its shape while it is kept (None: not kept)."""
    if len(_TREES) >= _MAX_TREES or sum(t[2] for t in _TREES.values()) + size > _MAX_TREE_BYTES:
        _TREES.clear()
    if size <= _MAX_TREE_BYTES:
        _TREES[key] = (tree, slots, size, next(_SHAPES))
        return _TREES[key][3]
    return None


def _keep(cache: dict, key, value):
    """``value`` stored under ``key`` in one of the writer's caches, which are emptied when full (a campaign uses a
    handful of entries; anything else would grow without bound)."""
    if len(cache) >= _MAX_CONNECTORS:
        cache.clear()
    cache[key] = value
    return value


def _template(cache: dict, key, tag: str, fill) -> etree._Element:
    """The element ``tag`` that ``fill`` completes, built once per ``key`` under a root declaring the SSD's namespaces
    (a copy taken into an SSD declares none of its own): a campaign's runs write the same components again and again."""
    element = cache.get(key)
    if element is None:
        holder = etree.Element(_q("ssd", "SystemStructureDescription"), nsmap=dict(NS))
        element = etree.SubElement(holder, tag)
        fill(element)
        _keep(cache, key, element)
    return element


# the shape of an SSD (SspBuilder._shape) -> its tree and the elements holding its inline values: a campaign writes the
# same system with other values run after run, and building the tree cost more than serialising it
_TREES: dict[tuple, tuple] = {}
_TREE_LOCK = threading.Lock()
_MAX_TREES = 16         # a campaign worker cycles through a handful of systems
_MAX_TREE_BYTES = 8 << 20   # serialised SSDs of all kept trees (4 UAVs: 160 kB; 256 UAVs: ~10 MB, not kept)
_KEEP_TREES = True      # tests compare with trees built afresh
_SHAPES = itertools.count()     # a kept tree's number: never the same for two shapes in one process
_CONNECTORS_XML: dict[tuple, etree._Element] = {}    # connectors -> their ssd:Connectors element
_PARAMETERS_XML: dict[tuple, etree._Element] = {}    # (name, type) of each parameter -> ssv:Parameters without values


def _connectors_element(connectors: tuple) -> etree._Element:
    def fill(conns):
        for cname, kind, typ, unit in connectors:
            c = etree.SubElement(conns, _q("ssd", "Connector"), name=cname, kind=kind)
            t = etree.SubElement(c, _q("ssc", typ if typ != "Enumeration" else "Integer"))
            if unit and typ == "Real":
                t.set("unit", unit)
    return _template(_CONNECTORS_XML, connectors, _q("ssd", "Connectors"), fill)


def _parameters_element(named_types: tuple) -> etree._Element:
    def fill(ps):
        for var, t in named_types:
            p = etree.SubElement(ps, _q("ssv", "Parameter"), name=var)
            etree.SubElement(p, _q("ssv", t))
    return _template(_PARAMETERS_XML, named_types, _q("ssv", "Parameters"), fill)


@dataclass
class SspBuilder:
    """A system built in code: the authoring API (OMSimulator's and libcosim's "system in code")::

        b = SspBuilder("osc", stop=10.0, step=0.01, algorithm="gauss-seidel")    # the settings are fields
        b.add_component("A", "MassA.fmu", params={"m": 1.0, "x0": 1.0})       # an FMU and parameter values
        b.add_component("B", "MassB.fmu")
        b.connect("A.x", "B.x_in").connect("B.F", "A.F")                     # output -> input
        ex = master.Execution(b, record=["A.*"])       # runs it from memory: no file is written
        b.write("osc.ssp")                             # ... or an SSP 1.0 archive any SSP tool reads

    Fields given to the constructor: ``start``, ``stop``, ``step``, ``algorithm``, ``record_interval``,
    ``step_multiples`` (component -> k), ``record`` (patterns), ``algorithm_options`` (``master.algorithm_options``
    names). The FMUs' paths are read when the system is written or run, not copied before."""
    name: str
    components: list = field(default_factory=list)
    connections: list = field(default_factory=list)   # (a, x, b, y, factor, offset, suppress, extrapolation)
    units: dict = field(default_factory=dict)         # name -> dict(base exponents, factor, offset)
    start: float | None = 0.0
    stop: float | None = None
    step: float | None = None
    algorithm: str | None = None
    record_interval: float | None = None
    step_multiples: dict = field(default_factory=dict)
    record: list = field(default_factory=list)        # record patterns
    algorithm_options: dict = field(default_factory=dict)   # master.algorithm_options name -> value
    annotations: list = field(default_factory=list)   # lxml elements with ssc:Annotation root
    # one name for every component's parameter set (Ecos applies only the set named in its init call); None:
    # "<component>-parameters"
    parameter_set: str | None = None

    def add_component(self, name, fmu_path, connectors=None, params=None, ssv=False):
        """connectors=None takes every input, output and set parameter from the FMU's modelDescription."""
        fmu_path = Path(fmu_path)
        params = dict(params or {})
        if connectors is None:
            connectors = _described_connectors(_description(fmu_path), params)
        typed = {}
        kinds = {c[0]: c[2] for c in connectors}
        for k, v in params.items():
            t = kinds.get(k) or ("Boolean" if isinstance(v, bool) else "Integer" if isinstance(v, int)
                                 else "Real" if isinstance(v, float) else "Binary" if isinstance(v, bytes)
                                 else "String")
            typed[k] = (t, v)
        self.components.append(_Comp(name, fmu_path, list(connectors), typed, f"{name}.ssv" if ssv else None))
        return self

    def connect(self, a, x, b=None, y=None, factor=None, offset=None, suppress_unit_conversion=False,
                extrapolation=None):
        """Connect component a's output x to component b's input y: ``connect(a, x, b, y)``, or with qualified
        names ``connect("a.x", "b.y")``, whose components must have been added (each end is checked against
        the component's connectors: a one-line ScenarioError names an unknown one and the close names).
        ``extrapolation``: the order for a's output x (an annotation on the connection)."""
        if b is None and y is None:
            (a, x), (b, y) = self._end(a, "output"), self._end(x, "input")
        self.connections.append((a, x, b, y, factor, offset, suppress_unit_conversion, extrapolation))
        return self

    def _end(self, qualified: str, kind: str) -> tuple[str, str]:
        """("component", "connector") of an added component named by "component.connector"; the longest
        component name that fits wins (names may hold dots)."""
        import difflib
        from ..errors import ScenarioError
        comps = {c.name: c for c in self.components}
        owner = next((n for n in sorted(comps, key=len, reverse=True) if qualified.startswith(n + ".")), None)
        if owner is None:
            near = difflib.get_close_matches(qualified.split(".")[0], list(comps), n=3)
            raise ScenarioError(f"no component of {qualified!r} has been added (components: "
                                f"{', '.join(comps) or 'none'})" + (f"; close: {', '.join(near)}" if near else ""),
                                element=f"connect {qualified}")
        name = qualified[len(owner) + 1:]
        names = [c[0] for c in comps[owner].connectors]
        if name not in names:
            near = difflib.get_close_matches(name, names, n=3)
            raise ScenarioError(f"component {owner!r} has no {kind} connector {name!r}"
                                + (f"; close: {', '.join(f'{owner}.{n}' for n in near)}" if near else ""),
                                element=f"connect {qualified}")
        return owner, name

    def in_memory(self) -> Path:
        """The system as an .ssp archive kept in this process's memory only, under a path that names no file:
        what ``Execution(builder)`` and ``master.run(builder)`` run. Nothing is written to disk."""
        import tempfile
        import uuid
        where = Path(tempfile.gettempdir()) / f"cosim-master-in-memory-{uuid.uuid4().hex[:12]}"
        return self.write(where / f"{self.name}.ssp", to_disk=False)

    # -- XML ------------------------------------------------------------------------------
    def _settings_annotation(self, parent):
        anns = etree.SubElement(parent, _q("ssd", "Annotations"))
        ours = etree.SubElement(anns, _q("ssc", "Annotation"), type=OUR_TYPE)
        s = etree.SubElement(ours, _q("cm", "Settings"))
        if self.step is not None:
            s.set("stepSize", _fmt(float(self.step)))
        if self.algorithm:
            s.set("algorithm", self.algorithm)
        if self.record_interval is not None:
            s.set("recordInterval", _fmt(float(self.record_interval)))
        from ..algorithm_options import ALGORITHM_OPTIONS
        for name, value in self.algorithm_options.items():
            s.set(ALGORITHM_OPTIONS[name].ssd_attribute, _fmt(value))
        for comp, k in self.step_multiples.items():
            etree.SubElement(s, _q("cm", "Component"), name=comp, stepMultiple=str(k))
        for pattern in self.record:
            etree.SubElement(s, _q("cm", "Record"), pattern=pattern)
        if self.step is not None:
            osp = etree.SubElement(anns, _q("ssc", "Annotation"), type="com.opensimulationplatform")
            alg = etree.SubElement(osp, _q("osp", "Algorithm"))
            etree.SubElement(alg, _q("osp", "FixedStepAlgorithm"), baseStepSize=_fmt(float(self.step)))

    def _params(self, values_parent, comp: _Comp, slots: list | None = None):
        """Inline under values_parent, or (None) as the root of an .ssv file; libcosim's parser matches the
        literal 'ssv:' prefix, so the file root declares it.  ``slots``: gets the elements holding the values."""
        attrs = {"version": "1.0", "name": self.parameter_set or f"{comp.name}-parameters"}
        if values_parent is None:
            pset = etree.Element(_q("ssv", "ParameterSet"), nsmap={"ssv": NS["ssv"]}, **attrs)
        else:
            pset = etree.SubElement(values_parent, _q("ssv", "ParameterSet"), **attrs)
        ps = copy.deepcopy(_parameters_element(tuple((var, t) for var, (t, _) in comp.params.items())))
        for p, (_, v) in zip(ps, comp.params.values()):
            p[0].set("value", _fmt(v))
        if slots is not None:
            slots.append([p[0] for p in ps])
        pset.append(ps)
        return pset

    def ssd_tree(self, fmu_names: dict[str, str]):
        return self._build_tree(fmu_names, None)

    def _build_tree(self, fmu_names: dict[str, str], slots: list | None):
        """The SSD's tree and the .ssv files' roots; ``slots`` gets, per component with inline values, the
        elements that hold them."""
        root = etree.Element(_q("ssd", "SystemStructureDescription"), nsmap={k: v for k, v in NS.items()},
                             version="1.0", name=self.name)
        system = etree.SubElement(root, _q("ssd", "System"), name=self.name)
        elements = etree.SubElement(system, _q("ssd", "Elements"))
        ssv_files = {}
        for comp in self.components:
            el = etree.SubElement(elements, _q("ssd", "Component"), name=comp.name,
                                  type="application/x-fmu-sharedlibrary", source=f"resources/{fmu_names[comp.name]}")
            el.append(copy.deepcopy(_connectors_element(tuple(comp.connectors))))
            if comp.params:
                pbs = etree.SubElement(el, _q("ssd", "ParameterBindings"))
                if comp.ssv:
                    etree.SubElement(pbs, _q("ssd", "ParameterBinding"), source=f"resources/{comp.ssv}")
                    ssv_files[comp.ssv] = self._params(None, comp)
                else:
                    pb = etree.SubElement(pbs, _q("ssd", "ParameterBinding"))
                    pv = etree.SubElement(pb, _q("ssd", "ParameterValues"))
                    self._params(pv, comp, slots)
        if self.connections:
            cs = etree.SubElement(system, _q("ssd", "Connections"))
            for a, x, b, y, factor, offset, sup, order in self.connections:
                c = etree.SubElement(cs, _q("ssd", "Connection"), startElement=a, startConnector=x, endElement=b,
                                     endConnector=y)
                if sup:
                    c.set("suppressUnitConversion", "true")
                if factor is not None or offset is not None:
                    etree.SubElement(c, _q("ssc", "LinearTransformation"), factor=_fmt(float(factor or 1.0)),
                                     offset=_fmt(float(offset or 0.0)))
                if order is not None:
                    write_connection_order(c, order, _q)
        if self.units:
            us = etree.SubElement(root, _q("ssd", "Units"))
            for name, spec in self.units.items():
                u = etree.SubElement(us, _q("ssc", "Unit"), name=name)
                etree.SubElement(u, _q("ssc", "BaseUnit"), **{k: _fmt(v) for k, v in spec.items()})
        exp = etree.SubElement(root, _q("ssd", "DefaultExperiment"))
        if self.start is not None:         # None: the FMUs' default experiments say (a bare FMU's system)
            exp.set("startTime", _fmt(float(self.start)))
        if self.stop is not None:
            exp.set("stopTime", _fmt(float(self.stop)))
        self._settings_annotation(exp)
        if self.annotations:
            anns = etree.SubElement(root, _q("ssd", "Annotations"))
            for a in self.annotations:
                anns.append(a)
        return etree.ElementTree(root), ssv_files

    def _shape(self, fmu_names: dict[str, str]) -> tuple:
        """Everything the SSD's tree is made of but the inline parameter values and the top-level annotations (the
        numbers as repr: 0.0 and -0.0 are equal keys, but not the same text)."""
        settings = (self.name, self.start, self.stop, self.step, self.algorithm, self.record_interval,
                    list(self.step_multiples.items()), self.record, list(self.algorithm_options.items()),
                    self.parameter_set, list(self.units.items()), self.connections)
        return (repr(settings), bool(self.annotations),
                tuple((c.name, fmu_names[c.name], tuple(c.connectors),
                       tuple((var, t) for var, (t, _) in c.params.items()), c.ssv) for c in self.components))

    def _ssd_bytes(self, fmu_names: dict[str, str], path: Path) -> tuple[bytes, dict, int | None]:
        """The SSD, validated and serialised, the .ssv files' roots and the number of its shape (None: a tree not
        kept).  A tree of the same shape written before (a campaign's runs of one system) gets this builder's values
        and annotations instead of being built again; it is validated and serialised as a new one would be.  SSDs of
        one shape differ only in attribute values (one line each: lxml writes a newline in one as &#10;) and in the
        top-level annotations, written last: their structure (``parser.structure_key``) is the same."""
        key = self._shape(fmu_names)
        with _TREE_LOCK:        # the kept trees are changed in place (Dask workers may run threads)
            kept = _TREES.get(key)
            if kept is None or not _KEEP_TREES:
                slots: list = []
                tree, ssv_files = self._build_tree(fmu_names, slots)
            else:
                tree, slots, _, shape = kept
                ssv_files = self._fill(tree, slots)
            xsd.validate(tree, "ssd", str(path))
            ssd = etree.tostring(tree, xml_declaration=True, encoding="UTF-8", pretty_print=True)
            if kept is None or not _KEEP_TREES:
                shape = _keep_tree(key, tree, slots, len(ssd)) if _KEEP_TREES else None
            return ssd, ssv_files, shape

    def _fill(self, tree, slots: list) -> dict:
        """Put this builder's values and annotations into a kept tree of its shape; returns the .ssv files' roots."""
        inline = (comp for comp in self.components if comp.params and not comp.ssv)
        for comp, elements in zip(inline, slots):
            for el, (_, v) in zip(elements, comp.params.values()):
                el.set("value", _fmt(v))
        if self.annotations:
            anns = tree.getroot()[-1]           # the top-level ssd:Annotations, written last
            for old in list(anns):
                anns.remove(old)
            for a in self.annotations:
                anns.append(a)
        return {comp.ssv: self._params(None, comp) for comp in self.components if comp.params and comp.ssv}

    def write(self, path, to_disk: bool = True) -> Path:
        """Write an .ssp archive (path ending in .ssp) or an unpacked SSP folder.  ``to_disk`` False: an archive is
        built for ``path`` but kept in this process's memory only (``archive.remember_written``), for a run that
        would delete the file unread afterwards; where a file is at ``path`` already, it is written all the same."""
        path = Path(path)
        fmu_names, seen, resolved = {}, {}, {}
        for comp in self.components:
            # instances of the same FMU share one archive member
            key = resolved.get(comp.fmu)
            if key is None:
                key = resolved[comp.fmu] = str(comp.fmu.resolve())
            if key not in seen:
                # the member's name is a URI in the SSD: "my model.fmu" is written as my_model.fmu
                stem = _URI_UNSAFE.sub("_", comp.fmu.stem)
                base = stem + comp.fmu.suffix
                taken = set(seen.values())
                name, k = base, 1
                while name in taken:
                    name, k = f"{stem}_{k}{comp.fmu.suffix}", k + 1
                seen[key] = name
            fmu_names[comp.name] = seen[key]
        ssd_bytes, ssv_files, shape = self._ssd_bytes(fmu_names, path)
        ssv_bytes = {name: etree.tostring(etree.ElementTree(el), xml_declaration=True, encoding="UTF-8",
                                          pretty_print=True) for name, el in ssv_files.items()}
        members = {f"resources/{name}": Path(src) for src, name in seen.items()}
        if path.suffix.lower() == ".ssp":
            files = {"SystemStructure.ssd": ssd_bytes, **{f"resources/{name}": data for name, data in ssv_bytes.items()}}
            fmus = {arc: _fmu_content(src) for arc, src in sorted(members.items())}
            chunks = _archive_chunks([*((arc, data, zlib.crc32(data)) for arc, data in files.items()),
                                      *((arc, data, crc) for arc, (data, _, crc) in fmus.items())])
            on_disk = to_disk or os.path.lexists(path)
            if on_disk:
                path.parent.mkdir(parents=True, exist_ok=True)
                tmp = path.with_suffix(".ssp.tmp")
                with open(tmp, "wb") as fh:
                    fh.writelines(chunks)
                os.replace(tmp, path)
            h = hashlib.sha256()
            for chunk in chunks:
                h.update(chunk)
            remember_written(path, h.hexdigest(), files, {arc: (sha, data) for arc, (data, sha, _) in fmus.items()},
                             on_disk, shape)
        else:
            if path.exists():
                shutil.rmtree(path)
            (path / "resources").mkdir(parents=True)
            (path / "SystemStructure.ssd").write_bytes(ssd_bytes)
            for name, data in ssv_bytes.items():
                (path / "resources" / name).write_bytes(data)
            for arc, src in members.items():
                shutil.copyfile(src, path / arc)
        return path


def one_fmu_system(fmu_path) -> SspBuilder:
    """A system of one component, the FMU at ``fmu_path`` named as its file's stem: every input and output a
    connector (so ``--input`` drives its inputs), its outputs recorded by default (FMPy's default; every variable
    where it has no output), and no time or step of its own: the FMU's default experiment gives them, and run.json
    says so."""
    fmu_path = Path(fmu_path)
    name = fmu_path.stem
    b = SspBuilder(name, start=None)
    b.add_component(name, fmu_path)
    outputs = [c[0] for c in b.components[0].connectors if c[1] == "output"]
    # each output, and each element of an array output (an FMI 3.0 y[2] records as y[0], y[1])
    b.record = [p for o in outputs for p in (f"{name}.{o}", glob.escape(f"{name}.{o}") + "[[]*]")] or [f"{name}.*"]
    return b


_URI_UNSAFE = re.compile(r"[^A-Za-z0-9._~-]")
_FMU_BYTES: dict[tuple, tuple[bytes, str, int]] = {}


def _fmu_content(src: Path) -> tuple[bytes, str, int]:
    """An FMU's bytes, their SHA-256 and their CRC-32 (``src``: a resolved path), read once per process while the
    file is unchanged: a campaign writes the same FMUs into every run's archive."""
    st = src.stat()
    key = (str(src), st.st_mtime_ns, st.st_size)
    content = _FMU_BYTES.get(key)
    if content is None:
        if len(_FMU_BYTES) >= 32:
            _FMU_BYTES.clear()
        data = src.read_bytes()
        content = _FMU_BYTES[key] = (data, hashlib.sha256(data).hexdigest(), zlib.crc32(data))
    return content


def _archive_chunks(members: list[tuple[str, bytes, int]]) -> list:
    """The bytes of the archive that ``zipfile.ZipFile(..., "w", ZIP_STORED)`` writes to a seekable file for these
    members ((name, data, CRC-32) written with ``writestr(_zinfo(name), data)`` in this order), as pieces that
    refer to the members' own data: the FMUs' megabyte is neither copied nor checksummed again for every run."""
    if not _plain_zip(members):
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:
            for name, data, _ in members:
                zf.writestr(_zinfo(name), data)
        return [buf.getvalue()]
    chunks, central, offset = [], [], 0
    for name, data, crc in members:
        zi = _zinfo(name)
        zi.CRC, zi.file_size, zi.compress_size, zi.header_offset = crc, len(data), len(data), offset
        header = zi.FileHeader(False)
        chunks += (header, data)
        dt = zi.date_time
        central.append(struct.pack(
            zipfile.structCentralDir, zipfile.stringCentralDir, zi.create_version, zi.create_system,
            zi.extract_version, zi.reserved, zi.flag_bits, zi.compress_type, dt[3] << 11 | dt[4] << 5 | dt[5] // 2,
            (dt[0] - 1980) << 9 | dt[1] << 5 | dt[2], crc, len(data), len(data), len(name), 0, 0, 0,
            zi.internal_attr, zi.external_attr, offset) + name.encode("ascii"))
        offset += len(header) + len(data)
    size = sum(map(len, central))
    end = struct.pack(zipfile.structEndArchive, zipfile.stringEndArchive, 0, 0, len(central), len(central), size,
                      offset, 0)
    return [*chunks, *central, end]


def _plain_zip(members) -> bool:
    """Members that zipfile writes without ZIP64 records or UTF-8 names (what _archive_chunks writes itself)."""
    total = sum(len(data) + 200 + len(name) for name, data, _ in members)
    return (len(members) < 0xFFFF and total < zipfile.ZIP64_LIMIT // 2
            and all(name.isascii() and not name.endswith("/") for name, _, _ in members))


def _zinfo(name):
    # fixed timestamps so that the same scenario gives a byte-identical archive
    zi = zipfile.ZipInfo(name, date_time=(2020, 1, 1, 0, 0, 0))
    zi.external_attr = 0o644 << 16
    return zi
