"""A campaign worker reads and plans each SSD structure once (``prepare(reuse_structure=True)``) and writes each
SSD shape once (``SspBuilder``'s kept trees).  What it hands a run must be what reading and planning afresh gives,
the run's own values included; no run may see another's values or changes; an edited FMU or scenario is read
again; the caches are bounded.  Each key part and each copy matters: leave one out and a test here fails.
"""
from __future__ import annotations

import dataclasses
import shutil
import zipfile
from pathlib import Path

import pytest
from lxml import etree

import master
from master.plan import reuse as plan_mod
from master.errors import ScenarioError
from master.execution import prepare
from master.ssp import archive, parser, writer
from master.ssp.writer import SspBuilder

ROOT = Path(__file__).resolve().parents[3]
PAPER = sorted((ROOT / "ssp").glob("paper_*.ssp"))


# ------------------------------------------------------------------------------------------------ views
def _model_view(m, root: Path) -> dict:
    """Everything a model holds, the run's temporary folder named alike."""
    def here(p):
        return str(p).replace(str(root), "<root>")
    return {
        "name": (m.name, m.version, m.start_time, m.stop_time),
        "components": {n: (c.source, c.type, c.implementation, c.line, here(c.fmu_path),
                           [(k, v.name, v.kind, v.type, v.unit, v.line) for k, v in c.connectors.items()])
                       for n, c in m.components.items()},
        "connections": [(c.src, c.dst, c.transformation and tuple(vars(c.transformation).values()),
                         c.suppress_unit_conversion, c.line, c.extrapolation) for c in m.connections],
        "parameters": [(p.component, p.variable, p.type, repr(p.value), p.origin, getattr(p, "unit", None))
                       for p in m.parameters],
        "units": {n: (u.name, repr(u.factor), repr(u.offset), u.exponents) for n, u in m.units.items()},
        "annotations": {k: etree.tostring(v) for k, v in m.annotations.items()},
        "settings": repr(m.settings),
    }


def _plan_view(p, root: Path) -> dict:
    def here(x):
        return str(x).replace(str(root), "<root>")
    return {
        "fmus": {n: (f.sha256, f.kind, here(f.path), str(f.unzip_dir), f.fmi_version) for n, f in p.fmus.items()},
        "links": [(ln.src.qualified, ln.dst.qualified, repr(ln.factor), repr(ln.offset), ln.mapping, ln.line)
                  for ln in p.links],
        "params": [(v.qualified, v.vr, repr(value), origin) for v, value, origin in p.params],
        "feedthrough": {c: {o: None if d is None else sorted(d) for o, d in outs.items()}
                        for c, outs in p.feedthrough.items()},
        "variables": {c: len(vs) for c, vs in p.variables.items()},
        "connected": {ln.dst.qualified: dict(vars(ln.dst)) for ln in p.links},
    }


def _views(scenario, **kw):
    pr = prepare(scenario, **kw)
    try:
        return _model_view(pr.model, pr.source.root), _plan_view(pr.plan, pr.source.root)
    finally:
        pr.source.close()


@pytest.fixture(autouse=True)
def _empty_caches():
    """Each test starts with a fresh worker's caches (and leaves none behind), the archives this process wrote or
    opened included: that store keeps 8 and empties itself when full, so an archive a test wrote could drop out
    between its two readings, depending on how many earlier tests wrote (it failed one full-suite run in eight)."""
    def clear():
        for cache in (parser._STRUCTURES, parser._PARAMETER_SETS, plan_mod._PLANS, writer._TREES,
                      archive._WRITTEN, archive._OPENED, archive._VALIDATED):
            cache.clear()
    clear()
    yield
    clear()


@pytest.fixture
def structure_reads(monkeypatch):
    """How many times the parser read a component's connectors (0: the structure was reused)."""
    calls = []
    read = parser._Reader.read_connectors
    monkeypatch.setattr(parser._Reader, "read_connectors", lambda self, *a: calls.append(1) or read(self, *a))
    return calls


# ------------------------------------------------------------------------------------- same as afresh
@pytest.mark.parametrize("ssp", PAPER, ids=lambda p: p.stem)
def test_a_reused_structure_gives_the_model_and_plan_a_fresh_read_gives(ssp, structure_reads):
    fresh = _views(ssp)
    first = _views(ssp, reuse_structure=True)
    structure_reads.clear()
    again = _views(ssp, reuse_structure=True, params={"uav1_strat.lookahead": 7.5}, seed=11)
    assert not structure_reads                      # read from the kept structure
    assert first == fresh
    assert again == _views(ssp, params={"uav1_strat.lookahead": 7.5}, seed=11)


def _gain_chain(path: Path, fmus, k1: float, k2: float, name="chain", extra=None) -> Path:
    """src (Integrator, from 1) -> g1 (Gain k1) -> g2 (Gain k2) -> back into src; values inline."""
    b = SspBuilder(name, stop=1.0, step=0.1)
    b.add_component("src", fmus["py:Integrator"], params={"x0": 1.0})
    b.add_component("g1", fmus["py:Gain"], params={"k": k1, **(extra or {})})
    b.add_component("g2", fmus["py:Gain"], params={"k": k2})
    b.connect("src", "y", "g1", "u")
    b.connect("g1", "y", "g2", "u")
    b.connect("g2", "y", "src", "u")
    return b.write(path)


def test_runs_of_one_structure_with_other_values_give_the_results_of_fresh_runs(tmp_path, test_fmus,
                                                                                structure_reads):
    a = _gain_chain(tmp_path / "a.ssp", test_fmus, 2.0, 3.0)
    b = _gain_chain(tmp_path / "b.ssp", test_fmus, -0.5, 4.25)
    tables = {}
    for label, ssp, reuse in (("a", a, True), ("b", b, True), ("b fresh", b, False), ("a fresh", a, False)):
        structure_reads.clear()
        res = master.run(ssp, output=None, reuse_structure=reuse)
        tables[label] = res.frame
        if label == "b":
            assert not structure_reads                # b's structure is a's
    assert tables["b"].equals(tables["b fresh"]) and tables["a"].equals(tables["a fresh"])
    assert not tables["a"]["src.y"].equals(tables["b"]["src.y"])        # b ran with its own values


# ------------------------------------------------------------------------------------------ no leaks
def test_a_run_sees_neither_the_values_nor_the_changes_of_an_earlier_run(tmp_path, test_fmus):
    ssp = _gain_chain(tmp_path / "a.ssp", test_fmus, 2.0, 3.0)
    want = _views(ssp)
    assert _views(ssp, reuse_structure=True) == want        # kept: the run below is handed the kept parts
    p1 = prepare(ssp, reuse_structure=True, params={"g1.k": 9.0}, seed=5)
    m, pl = p1.model, p1.plan
    # everything a later phase could change in place
    pl.params.append(pl.params[0])
    pl.links[0].factor = 99.0
    pl.links.pop()
    next(iter(pl.feedthrough["g1"].values())).add("src")
    pl.feedthrough["g2"].clear()
    pl.variables.pop("src")
    pl.fmus["g1"].kind = "ModelExchange"
    m.connections[0].dst_connector = "k"
    m.connections.append(m.connections[0])
    m.components["g1"].source = "elsewhere.fmu"
    m.components.pop("g2")
    m.parameters.clear()
    m.units["mm"] = m.units.get("mm")
    with pytest.raises(TypeError):                      # the shared connectors are read-only
        m.components["src"].connectors["x"] = None
    p1.source.close()
    assert _views(ssp, reuse_structure=True) == want
    assert _views(ssp, reuse_structure=True) == want


# ------------------------------------------------------------------------------------ invalidation
def test_an_fmu_edited_between_runs_is_planned_again(tmp_path, test_fmus):
    folder = _gain_chain(tmp_path / "chain", test_fmus, 2.0, 3.0)         # an SSP folder: its FMUs are files
    before = _views(folder, reuse_structure=True)
    shutil.copyfile(test_fmus["c2:Gain"], folder / "resources" / "Gain.fmu")    # same variables, other FMU
    after = _views(folder, reuse_structure=True)
    assert after == _views(folder)
    assert after[1]["fmus"]["g1"][0] != before[1]["fmus"]["g1"][0]
    shutil.copyfile(test_fmus["py:MassA"], folder / "resources" / "Gain.fmu")    # one without k, u, y
    with pytest.raises(ScenarioError) as reused:
        prepare(folder, reuse_structure=True)
    with pytest.raises(ScenarioError) as fresh:
        prepare(folder)
    assert str(reused.value) == str(fresh.value)


def test_a_scenario_edited_between_runs_is_read_again(tmp_path, test_fmus, structure_reads):
    folder = _gain_chain(tmp_path / "chain", test_fmus, 2.0, 3.0)
    ssd = folder / "SystemStructure.ssd"
    _views(folder, reuse_structure=True)
    text = ssd.read_text()
    edits = [text.replace('endElement="g2" endConnector="u"', 'endElement="g2" endConnector="k"'),   # a connection
             text.replace('<ssc:Real/>', '<ssc:Real unit="m"/>', 1),                    # a connector
             text.replace('name="chain"', 'name="chained"')]                             # the system's name
    for edited in edits:
        assert edited != text
        ssd.write_text(edited)
        structure_reads.clear()
        assert _views(folder, reuse_structure=True) == _views(folder)
        assert structure_reads                                                  # read, not reused


def test_values_spanning_other_lines_move_the_lines_of_what_follows(tmp_path, test_fmus):
    """A run's messages name the lines of its own file: a structure whose values took more lines is another key."""
    folder = _gain_chain(tmp_path / "chain", test_fmus, 2.0, 3.0)
    ssd = folder / "SystemStructure.ssd"
    _views(folder, reuse_structure=True)
    text = ssd.read_text()
    ssd.write_text(text.replace("<ssv:Parameters>", "<ssv:Parameters>\n\n\n", 1))    # in g1's values only
    reused = _views(folder, reuse_structure=True)
    assert reused == _views(folder)
    lines = reused[0]["components"]["g2"][3]
    assert lines == _views(folder)[0]["components"]["g2"][3]


def test_a_structure_key_leaves_out_the_values_and_keeps_the_rest(tmp_path, test_fmus):
    def key(path):
        return parser.structure_key(etree.parse(str(path / "SystemStructure.ssd")).getroot())
    a = key(_gain_chain(tmp_path / "a", test_fmus, 2.0, 3.0))
    assert key(_gain_chain(tmp_path / "b", test_fmus, 5.0, -1.0)) == a            # other values
    assert key(_gain_chain(tmp_path / "c", test_fmus, 2.0, 3.0, name="other")) != a
    assert key(_gain_chain(tmp_path / "d", test_fmus, 2.0, 3.0, extra={"u": 1.0})) != a   # another connector


# ------------------------------------------------------------------------------------------- bounds
def test_the_caches_are_bounded(tmp_path, test_fmus, monkeypatch):
    monkeypatch.setattr(parser, "_MAX_STRUCTURES", 3)
    monkeypatch.setattr(parser, "_MAX_PARAMETER_SETS", 4)
    monkeypatch.setattr(plan_mod, "_MAX_PLANS", 3)
    monkeypatch.setattr(writer, "_MAX_TREES", 2)
    for i in range(7):
        ssp = _gain_chain(tmp_path / f"s{i}.ssp", test_fmus, float(i), 1.0, name=f"chain{i}")
        _views(ssp, reuse_structure=True)
        assert len(parser._STRUCTURES) <= 3 and len(plan_mod._PLANS) <= 3
        assert len(parser._PARAMETER_SETS) <= 4 and len(writer._TREES) <= 2
    assert parser._STRUCTURES and plan_mod._PLANS          # still kept after emptying


def test_what_is_over_the_size_bounds_is_not_kept(tmp_path, test_fmus, monkeypatch):
    ssp = _gain_chain(tmp_path / "a.ssp", test_fmus, 2.0, 3.0)
    monkeypatch.setattr(parser, "_MAX_KEPT_SIZE", 11)           # the chain: 9 connectors and 3 connections
    monkeypatch.setattr(plan_mod, "_MAX_KEPT_LINKS", 2)         # 3 links
    monkeypatch.setattr(parser, "_MAX_PARAMETER_BYTES", 100)    # each set's XML is longer
    monkeypatch.setattr(writer, "_MAX_TREE_BYTES", 1000)        # the SSD is longer
    writer._TREES.clear()
    _gain_chain(tmp_path / "b.ssp", test_fmus, 2.0, 3.0)
    want = _views(ssp)
    assert _views(ssp, reuse_structure=True) == want == _views(ssp, reuse_structure=True)
    assert not parser._STRUCTURES and not plan_mod._PLANS and not parser._PARAMETER_SETS and not writer._TREES
    monkeypatch.setattr(parser, "_MAX_KEPT_SIZE", 12)
    monkeypatch.setattr(plan_mod, "_MAX_KEPT_LINKS", 3)
    monkeypatch.setattr(parser, "_MAX_PARAMETER_BYTES", 10_000)
    monkeypatch.setattr(writer, "_MAX_TREE_BYTES", 100_000)
    _gain_chain(tmp_path / "c.ssp", test_fmus, 2.0, 3.0)
    assert _views(ssp, reuse_structure=True) == want
    assert parser._STRUCTURES and plan_mod._PLANS and parser._PARAMETER_SETS and writer._TREES


def test_a_single_run_keeps_nothing(tmp_path, test_fmus):
    ssp = _gain_chain(tmp_path / "a.ssp", test_fmus, 2.0, 3.0)
    _views(ssp)
    assert not parser._STRUCTURES and not plan_mod._PLANS and not parser._PARAMETER_SETS


# ------------------------------------------------------------------------------------- kept SSD trees
def _uav_builders():
    """Builders of every shipped paper scenario, written twice with other values and annotations."""
    from uavstudy import build
    from uavstudy.scenario import load_scenario_yaml
    made = []
    for yml in sorted((ROOT / "ssp" / "scenarios").glob("paper_*.yaml")):
        scn = load_scenario_yaml(yml)
        for strategy, p in (("A", 0.05), ("B", 0.1), ("A", 0.0)):
            made.append(dataclasses.replace(scn, strategy=strategy,
                                            wind=dataclasses.replace(scn.wind, probability=p), seed=len(made)))
    return build, made


def test_an_ssd_written_from_a_kept_tree_is_the_one_built_afresh(tmp_path, monkeypatch):
    build, scenarios = _uav_builders()
    assert scenarios
    for i, scn in enumerate(scenarios):
        monkeypatch.setattr(writer, "_KEEP_TREES", True)
        kept = zipfile.ZipFile(build.build_ssp(scn, tmp_path / f"k{i}.ssp")).read("SystemStructure.ssd")
        monkeypatch.setattr(writer, "_KEEP_TREES", False)
        fresh = zipfile.ZipFile(build.build_ssp(scn, tmp_path / f"f{i}.ssp")).read("SystemStructure.ssd")
        assert kept == fresh, scn.name
    assert 0 < len(writer._TREES) < len(scenarios)                 # shapes were shared


def test_a_kept_tree_takes_the_values_of_components_in_ssv_files(tmp_path, test_fmus, monkeypatch):
    def write(k, name):
        b = SspBuilder("chain", stop=1.0, step=0.1)
        b.add_component("g1", test_fmus["py:Gain"], params={"k": k}, ssv=True)
        b.add_component("g2", test_fmus["py:Gain"], params={"k": -k})
        b.connect("g1", "y", "g2", "u")
        return b.write(tmp_path / name)
    write(1.0, "first.ssp")
    monkeypatch.setattr(writer, "_KEEP_TREES", True)
    kept = zipfile.ZipFile(write(2.5, "kept.ssp"))
    monkeypatch.setattr(writer, "_KEEP_TREES", False)
    fresh = zipfile.ZipFile(write(2.5, "fresh.ssp"))
    assert kept.namelist() == fresh.namelist()
    for name in kept.namelist():
        assert kept.read(name) == fresh.read(name), name
    assert b'value="2.5"' in kept.read("resources/g1.ssv")


# --------------------------------------------------------------------------- archives opened before
def _layout(folder: Path) -> dict:
    return {str(p.relative_to(folder)): (p.is_symlink(), p.read_bytes() if p.is_file() else None)
            for p in sorted(folder.rglob("*"))}


@pytest.fixture
def opened_archive(tmp_path, test_fmus, monkeypatch):
    """A chain archive this process did not write (as a campaign over a shipped SSP), with its own FMU store."""
    from master.ssp import archive
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    archive._OPENED.clear()
    written = _gain_chain(tmp_path / "written.ssp", test_fmus, 2.0, 3.0)
    with zipfile.ZipFile(written) as zf, zipfile.ZipFile(tmp_path / "shipped.ssp", "w") as out:
        out.writestr("resources/", b"")                            # folder entries, as some zip tools write
        out.writestr("documentation/", b"")                        # (this one stays empty)
        for info in zf.infolist():
            out.writestr(info, zf.read(info))
    yield tmp_path / "shipped.ssp"
    archive._OPENED.clear()


def test_an_archive_opened_before_opens_as_its_extraction_without_reading_its_fmus(opened_archive, monkeypatch):
    from master.ssp import archive
    import hashlib
    first = archive.open_scenario(opened_archive)
    extracted = archive._extract_ssp(opened_archive)
    reads = []
    link = archive._link_fmu
    monkeypatch.setattr(archive, "_link_fmu", lambda *a: reads.append(1) or link(*a))
    again = archive.open_scenario(opened_archive)
    try:
        assert _layout(again.root) == _layout(first.root) == _layout(extracted)
        assert not reads
        want = hashlib.sha256(opened_archive.read_bytes()).hexdigest()
        assert archive.file_sha256(opened_archive) == want == archive.file_sha256(opened_archive)
        assert archive._OPENED[str(opened_archive)].sha256 == want
    finally:
        for src in (first, again):
            src.close()
        shutil.rmtree(extracted)


def test_an_archive_changed_since_it_was_opened_is_read_again(opened_archive, tmp_path):
    import hashlib
    import os
    from master.ssp import archive
    assert _views(opened_archive)[0]["parameters"][1][3] == "2.0"
    archive.file_sha256(opened_archive)
    data = opened_archive.read_bytes()
    st = opened_archive.stat()
    changed = _rewritten(opened_archive, tmp_path / "changed.ssp", b'value="2.0"', b'value="7.0"').read_bytes()
    assert changed != data and len(changed) == len(data)
    opened_archive.write_bytes(changed)
    os.utime(opened_archive, ns=(st.st_atime_ns, st.st_mtime_ns))     # only the change time tells
    assert archive.file_sha256(opened_archive) == hashlib.sha256(changed).hexdigest()
    assert _views(opened_archive)[0]["parameters"][1][3] == "7.0"


def _rewritten(ssp: Path, to: Path, old: bytes, new: bytes) -> Path:
    """A copy of the archive with ``old`` replaced by ``new`` in its SSD."""
    with zipfile.ZipFile(ssp) as zf:
        members = [(info, zf.read(info)) for info in zf.infolist()]
    with zipfile.ZipFile(to, "w") as out:
        for info, data in members:
            out.writestr(info, data.replace(old, new) if info.filename == "SystemStructure.ssd" else data)
    return to


def test_an_archive_opened_before_is_validated_again(opened_archive, tmp_path):
    bad = _rewritten(opened_archive, tmp_path / "bad.ssp", b"<ssd:Elements>", b'<ssd:Elements bogus="1">')
    for _ in range(2):
        with pytest.raises(ScenarioError, match="schema"):
            prepare(bad)


def test_an_fmu_gone_from_the_store_is_unpacked_from_the_archive_again(opened_archive, tmp_path):
    from master.fmi.cache import cache_root
    want = _views(opened_archive)
    for kept in (cache_root() / "archived").glob("*.fmu"):
        kept.unlink()
    assert _views(opened_archive) == want
