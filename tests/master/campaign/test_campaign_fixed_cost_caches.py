"""The per-process caches that cut a campaign run's fixed cost each give what the uncached path gives, and each
part of their keys matters: leave one out and a test here fails.

* ZoneMap: one map per zones (to the bit) and margin, shared by strategies and by their FMU states;
* record patterns: the names a pattern set selects per component, kept per FMU description;
* archives this process wrote: opened from the members in memory while the file is still the one written;
* SSD connectors of an FMU per parameter set, and their XML element;
* plan Vars copied from the FMU's description;
* the UavStrategy shell's indexed mission parameters, set in one update by later instances.
"""
import hashlib
import math
import os
import random
import sys
import zipfile
from pathlib import Path

import pytest
from lxml import etree

from master.execution import prepare
from master.observers import recording
from master.observers.recording import select_variables
from master.plan.model import Var
from master.records import replaced
from master.ssp import archive, writer
from master.ssp.archive import _extract_ssp, file_sha256, open_scenario
from uavsim.strategy import ZoneMap

ROOT = Path(__file__).resolve().parents[3]
SSP = ROOT / "ssp" / "paper_zones_4uav_B.ssp"
SQUARE = [(40.0, -5.0), (60.0, -5.0), (60.0, 30.0), (40.0, 30.0)]


def _fresh_map(zones, margin):
    """A ZoneMap built outside the cache (what every strategy built before there was one)."""
    zm = object.__new__(ZoneMap)
    zm._build([list(z) for z in zones], margin)
    return zm


# --------------------------------------------------------------------------------------------- ZoneMap
def _reused(zones, margin) -> bool:
    """Does ZoneMap(zones, margin) hand out a map built before (the one just let go)?"""
    first = ZoneMap(zones, margin)
    kept = id(first)
    del first
    return id(ZoneMap(zones, margin)) == kept


def test_a_zone_map_let_go_is_reused_for_the_same_zones_and_margin():
    assert _reused([SQUARE], 3.0)
    assert _reused([[tuple(p) for p in SQUARE]], 3)             # the same zones given anew
    # a map held (by a strategy) is not handed out again: each strategy of a run has its own
    a = ZoneMap([SQUARE], 3.0)
    b = ZoneMap([SQUARE], 3.0)
    assert b is not a and ZoneMap([SQUARE], 3.0) not in (a, b)


@pytest.mark.parametrize("other", [
    ([SQUARE], 3.5),                                            # the margin is part of the key
    ([SQUARE[:3]], 3.0),                                        # so is every vertex
    ([[SQUARE[0], (60.0, -5.0 + 2 ** -40), *SQUARE[2:]]], 3.0),  # to the last bit
    ([[(-0.0, -5.0), *SQUARE[1:]]], 3.0),
    ([], 3.0),
])
def test_a_zone_map_is_not_reused_for_other_zones_or_margins(other):
    base = [[(0.0, -5.0), *SQUARE[1:]]]
    first = ZoneMap(base, 3.0)
    kept = id(first)
    del first
    assert id(ZoneMap(*other)) != kept


def test_a_shared_zone_map_answers_as_a_fresh_one():
    rng = random.Random(5)
    zones = [[(x + 30.0 * k, y + 20.0 * k) for x, y in SQUARE] for k in range(3)]
    first = ZoneMap(zones, 2.0)
    for margin in (4.0, 2.0, 7.5):           # planners of other margins built first on the map
        first.plan((0.0, 0.0), (150.0, 90.0), margin)
    first.detour((0.0, 0.0), (150.0, 90.0))
    kept = id(first)
    del first
    shared = ZoneMap(zones, 2.0)
    assert id(shared) == kept
    fresh = _fresh_map(zones, 2.0)
    for _ in range(200):
        a = (rng.uniform(-20, 200), rng.uniform(-40, 120))
        b = (rng.uniform(-20, 200), rng.uniform(-40, 120))
        assert shared.blocked(a, b) == fresh.blocked(a, b)
        assert shared.detour(a, b) == fresh.detour(a, b)
        margin = rng.choice((2.0, 4.0, 6.0))
        assert shared.plan(a, b, margin) == fresh.plan(a, b, margin)


def test_the_fmu_state_of_a_strategy_keeps_its_zone_map():
    from uavsim.fmi import _copy
    zm = ZoneMap([SQUARE], 3.0)
    state = _copy({"zones": zm}, {})
    assert state["zones"] is zm                 # a deep copy (FMU state) keeps the map ...
    kept = id(zm)
    del zm
    assert id(ZoneMap([SQUARE], 3.0)) != kept   # ... and holds it: not handed to another strategy


# ------------------------------------------------------------------------------------- record patterns
def _select_uncached(plan, patterns):
    import fnmatch
    out = []
    for comp, vars_ in plan.variables.items():
        for name in vars_:
            q = f"{comp}.{name}"
            if any(fnmatch.fnmatchcase(q, p) or q == p for p in patterns):
                v = vars_[name]
                if v.type in recording.ARROW_TYPES and not v.is_array:
                    out.append(v)
    return out


def test_recorded_variables_as_matched_without_the_cache():
    p = prepare(SSP)
    try:
        for patterns in (["*.x", "*.photo_count"], ["uav2_*.x"], ["uav1_strat.target_x_*", "*.soc"], ["*.x"]):
            assert select_variables(p.plan, patterns, []) == _select_uncached(p.plan, patterns), patterns
    finally:
        p.source.close()


def test_the_selection_cache_keys_on_patterns_component_and_description():
    p = prepare(SSP)
    try:
        plan = p.plan
        x = {v.qualified for v in select_variables(plan, ["uav1_*.x"], [])}
        assert x == {"uav1_dyn.x", "uav1_strat.x"}
        # another component with the same FMU, other patterns: their own answers
        assert {v.qualified for v in select_variables(plan, ["uav2_*.x"], [])} == {"uav2_dyn.x", "uav2_strat.x"}
        assert {v.qualified for v in select_variables(plan, ["uav1_*.y"], [])} == {"uav1_dyn.y", "uav1_strat.y"}
        # the same component name over another FMU (the description is part of the key)
        strat, dyn = plan.variables["uav1_strat"], plan.variables["uav1_dyn"]
        swapped = type("P", (), {"variables": {"uav1_strat": type(strat)("uav1_strat", dyn.described)}})()
        got = [v.name for v in select_variables(swapped, ["uav1_strat.*"], [])]
        assert got == [v.name for v in _select_uncached(swapped, ["uav1_strat.*"])] and "airspeed" in got
    finally:
        p.source.close()


# --------------------------------------------------------------------------- archives this process wrote
def _tree(folder: Path) -> dict:
    return {str(p.relative_to(folder)): (p.is_symlink(), p.read_bytes()) for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _chain(tmp_path, k, chain_fmus):
    from campaign_helpers import write_chain_ssp
    return write_chain_ssp(tmp_path / "chain.ssp", chain_fmus, k=k)


def test_a_written_archive_opens_as_its_extraction(tmp_path, chain_fmus, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    ssp = _chain(tmp_path, 2.0, chain_fmus)
    assert archive._written(ssp) is not None
    assert file_sha256(ssp) == hashlib.sha256(ssp.read_bytes()).hexdigest()
    src = open_scenario(ssp)
    extracted = _extract_ssp(ssp)
    try:
        assert _tree(src.root) == _tree(extracted)
    finally:
        src.close()


def _with_gain(ssp: Path, tmp_path: Path, gain: bytes) -> bytes:
    """The bytes of the archive ``ssp`` with the gain's value 2.0 changed to ``gain`` (same length)."""
    with zipfile.ZipFile(ssp) as zf:
        members = [(info.filename, zf.read(info)) for info in zf.infolist()]
    rewritten = tmp_path / "rewritten.ssp"
    with zipfile.ZipFile(rewritten, "w", zipfile.ZIP_STORED) as zf:
        for name, member in members:
            zf.writestr(writer._zinfo(name), member.replace(b'value="2.0"', b'value="' + gain + b'"')
                        if name == "SystemStructure.ssd" else member)
    return rewritten.read_bytes()


def test_an_archive_changed_after_writing_is_read_from_disk(tmp_path, chain_fmus, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    ssp = _chain(tmp_path, 2.0, chain_fmus)
    data = ssp.read_bytes()
    st = ssp.stat()
    # the same file and size, the gain changed inside the SSD, the mtime put back: only the inode's change
    # time tells
    with zipfile.ZipFile(ssp) as zf:
        ssd = zf.read("SystemStructure.ssd")
    changed = _with_gain(ssp, tmp_path, b"3.0")
    assert changed != data and len(changed) == len(data)
    with open(ssp, "r+b") as fh:
        fh.write(changed)
    os.utime(ssp, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert file_sha256(ssp) == hashlib.sha256(changed).hexdigest()
    src = open_scenario(ssp)
    try:
        now = (src.root / "SystemStructure.ssd").read_bytes()
        assert now == ssd.replace(b'value="2.0"', b'value="3.0"') != ssd
    finally:
        src.close()


def test_an_archive_replaced_by_another_file_is_read_from_disk(tmp_path, chain_fmus, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    ssp = _chain(tmp_path, 2.0, chain_fmus)
    other = tmp_path / "other.ssp"
    other.write_bytes(_with_gain(ssp, tmp_path, b"4.0"))
    os.replace(other, ssp)
    src = open_scenario(ssp)
    try:
        assert b'value="4.0"' in (src.root / "SystemStructure.ssd").read_bytes()
    finally:
        src.close()


# ------------------------------------------------------------------------------------- SSD connectors
def _connectors_uncached(md, params):
    out = []
    for v in md.modelVariables:
        if v.causality in ("input", "output") or (v.causality == "parameter" and v.name in params):
            t = {"Float64": "Real", "Float32": "Real"}.get(v.type, v.type)
            out.append((v.name, v.causality, "Integer" if t.startswith(("Int", "UInt")) else t,
                        getattr(v, "unit", None)))
    return tuple(out)


def test_connectors_per_description_and_parameter_set():
    from master.fmi.cache import load_fmu
    strat = load_fmu(ROOT / "fmus" / "UavStrategy.fmu").md
    dyn = load_fmu(ROOT / "fmus" / "UavDynamics.fmu").md
    for md, params in ((strat, {"strategy": "A"}), (strat, {"strategy": "B", "n_targets": 3}), (strat, {}),
                       (dyn, {"speed": 5.0}), (dyn, {"speed": 5.0, "accel": 1.0})):
        assert writer._described_connectors(md, params) == _connectors_uncached(md, params)


def test_the_connectors_element_serialises_as_built_in_place():
    conns = (("u", "input", "Real", "m"), ("n", "parameter", "Integer", None), ("e", "output", "Enumeration", None))
    b = writer.SspBuilder("t")
    root = etree.Element(writer._q("ssd", "SystemStructureDescription"), nsmap=dict(writer.NS))
    el = etree.SubElement(root, writer._q("ssd", "Component"), name="c")
    el.append(__import__("copy").deepcopy(writer._connectors_element(conns)))
    by_hand = etree.Element(writer._q("ssd", "SystemStructureDescription"), nsmap=dict(writer.NS))
    c = etree.SubElement(by_hand, writer._q("ssd", "Component"), name="c")
    cs = etree.SubElement(c, writer._q("ssd", "Connectors"))
    for name, kind, typ, unit in conns:
        x = etree.SubElement(cs, writer._q("ssd", "Connector"), name=name, kind=kind)
        t = etree.SubElement(x, writer._q("ssc", typ if typ != "Enumeration" else "Integer"))
        if unit and typ == "Real":
            t.set("unit", unit)
    assert etree.tostring(root, pretty_print=True) == etree.tostring(by_hand, pretty_print=True)
    assert b is not None


# ------------------------------------------------------------------------------------------ plan Vars
def test_a_renamed_var_is_the_var_made_with_its_component():
    rng = random.Random(11)
    for _ in range(200):
        fields = dict(name=rng.choice("abc"), vr=rng.randint(0, 99), type="Real", fmi_type="Float64",
                      causality=rng.choice(["input", "output"]), variability="continuous",
                      unit=rng.choice([None, "m"]), shape=rng.choice([(), (2,)]), index=rng.choice([None, 1]),
                      start=rng.choice([None, 1.5, (1.0, math.nan)]))
        v = Var("", **fields)
        comp = rng.choice(["uav1_dyn", "x.y"])
        a, b = Var(comp, **fields), replaced(v, component=comp)
        assert a == b and hash(a) == hash(b) and repr(a) == repr(b) and a.qualified == b.qualified
        assert v.component == ""                     # the description's Var is left as it was


# ---------------------------------------------------------------------------- UavStrategy's registration
def _strategy_class():
    sys.path.insert(0, str(ROOT / "fmu_sources"))
    import UavStrategy
    return UavStrategy


def _state(obj) -> dict:
    return {k: v for k, v in obj.__dict__.items() if k not in ("instance_name", "guid", "log_queue")}


def test_later_strategy_instances_equal_the_first():
    mod = _strategy_class()
    cls = type("FreshStrategy", (mod.UavStrategy,), {})     # its own variable table, first instance included
    first = cls(instance_name="a", resources=".", visible=False)
    later = cls(instance_name="b", resources=".", visible=False)
    assert "_var_table" in cls.__dict__ and later.vars is first.vars
    assert list(_state(later)) == list(_state(first)) and _state(later) == _state(first)
    assert later.n_targets == mod.M.NOT_GIVEN and later.target_x_1 == 0.0


def test_a_table_that_does_not_hold_the_indexed_names_registers_one_by_one(monkeypatch):
    mod = _strategy_class()
    cls = type("OtherStrategy", (mod.UavStrategy,), {})
    first = cls(instance_name="a", resources=".", visible=False)
    # a run of names that is not the table's next: the bulk update is refused, each is registered (and checked)
    monkeypatch.setattr(mod, "_INDEXED_NAMES", mod._INDEXED_NAMES[1:])
    calls = []
    monkeypatch.setattr(cls, "par_real", lambda self, *a: (calls.append(a[0]), mod.UavStrategy.par_real(self, *a)))
    later = cls(instance_name="b", resources=".", visible=False)
    assert "target_x_1" in calls and len(calls) > 1000
    assert _state(later) == _state(first)


def _params_by_hand(builder, values_parent, comp):
    """SspBuilder._params element by element (before the cached template)."""
    q = writer._q
    attrs = {"version": "1.0", "name": builder.parameter_set or f"{comp.name}-parameters"}
    if values_parent is None:
        pset = etree.Element(q("ssv", "ParameterSet"), nsmap={"ssv": writer.NS["ssv"]}, **attrs)
    else:
        pset = etree.SubElement(values_parent, q("ssv", "ParameterSet"), **attrs)
    ps = etree.SubElement(pset, q("ssv", "Parameters"))
    for var, (t, v) in comp.params.items():
        p = etree.SubElement(ps, q("ssv", "Parameter"), name=var)
        etree.SubElement(p, q("ssv", t), value=writer._fmt(v))
    return pset


@pytest.mark.parametrize("inline", [True, False])
def test_parameter_values_serialise_as_built_element_by_element(inline):
    rng = random.Random(4)
    b = writer.SspBuilder("t")
    for k in range(30):
        params = {f"p{j}": rng.choice([rng.random() * 10 ** rng.randint(-9, 9), rng.randint(-5, 5), True,
                                       'a&b<"c"\n\td', b"\x00\xff", -0.0])
                  for j in rng.sample(range(12), rng.randint(0, 12))}
        b.add_component(f"c{k % 3}", ROOT / "fmus" / "UavBattery.fmu", connectors=[], params=params)
        comp = b.components[-1]

        def holder():
            root = etree.Element(writer._q("ssd", "SystemStructureDescription"), nsmap=dict(writer.NS))
            return root, etree.SubElement(root, writer._q("ssd", "ParameterValues"))
        (r1, v1), (r2, v2) = holder(), holder()
        ours = b._params(v1 if inline else None, comp)
        ref = _params_by_hand(b, v2 if inline else None, comp)
        assert etree.tostring(r1 if inline else ours) == etree.tostring(r2 if inline else ref)


def test_only_the_ssd_as_written_skips_the_schema(tmp_path, chain_fmus, monkeypatch):
    """The writer validated the SSD it wrote: reading it back need not.  Changed since, it is validated."""
    from master.errors import ScenarioError
    from master.ssp.parser import read_ssd
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    ssp = _chain(tmp_path, 2.0, chain_fmus)
    src = open_scenario(ssp)
    try:
        assert archive.schema_checked(src.ssd_path)
        read_ssd(src.ssd_path, src.root)
        text = src.ssd_path.read_bytes()
        src.ssd_path.write_bytes(text.replace(b'<ssd:System name="chain"', b'<ssd:System name="chain" bogus="1"', 1))
        assert not archive.schema_checked(src.ssd_path)
        with pytest.raises(ScenarioError, match="does not conform to the SSP schema"):
            read_ssd(src.ssd_path, src.root)
    finally:
        src.close()
