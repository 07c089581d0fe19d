"""Archives this process wrote are read from memory (master.ssp.archive.open_scenario(in_memory=True)): no unpacked
folder, no FMU links, the SSD parsed from the writer's bytes.  What a run reads that way must be what it reads from
the archive unpacked (the parse result, the messages), and what a user keeps must be the archive byte for byte."""
from __future__ import annotations

import hashlib
import io
import os
import pickle
import random
import string
import warnings
import zipfile
import zlib
from pathlib import Path

import pytest

import master
from master import yamlio
from master.errors import ScenarioError
from master.ssp import archive, parser, writer
from master.ssp.archive import open_scenario
from master.ssp.parser import read_ssd, structure_key
from master.ssp.writer import SspBuilder


@pytest.fixture(scope="module")
def fmus(test_fmus):
    return {"faulty": test_fmus["c2:Faulty"], "gain": test_fmus["c2:Gain"], "integ": test_fmus["py:Integrator"]}


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))


def _chain(fmus, k=2.0, label="chain", wrong_connector=False) -> SspBuilder:
    b = SspBuilder("chain")
    b.stop, b.step = 1.0, 0.1
    b.add_component("src", fmus["faulty"], params={"fail_time": 0.5, "mode": 0})
    b.add_component("gain", fmus["gain"], params={"k": float(k)})
    b.add_component("gain2", fmus["gain"], params={"k": 0.5})      # a second instance: one archive member
    b.add_component("integ", fmus["integ"], params={"a": 0.0, "x0": 0.0})
    b.connect("src", "y", "gain", "u")
    b.connect("gain", "y", "gain2", "u")
    b.connect("gain2", "y" if not wrong_connector else "nope", "integ", "u")
    b.add_component("label", fmus["gain"], params={"k": 1.0})
    b.annotations.append(_annotation(label))
    b.record = ["src.y", "gain.y", "integ.y"]
    return b


def _annotation(text: str):
    from lxml import etree
    ann = etree.Element(writer._q("ssc", "Annotation"), type="org.example.label")
    etree.SubElement(ann, "{urn:example}Label", text=text)
    return ann


def _model_facts(model) -> dict:
    """Everything a run takes from the parsed SSD, the FMUs by their content."""
    comps = {name: (c.source, c.type, c.line, c.implementation, hashlib.sha256(c.fmu_path.read_bytes()).hexdigest(),
                    {k: tuple(vars(v).values()) for k, v in c.connectors.items()})
             for name, c in model.components.items()}
    conns = [tuple(vars(c).values()) for c in model.connections]
    params = [(p.component, p.variable, p.type, p.value, p.origin, p.unit) for p in model.parameters]
    anns = {k: pickle.dumps(str(v.attrib)) for k, v in model.annotations.items()}
    return {"name": model.name, "version": model.version, "components": comps, "connections": conns,
            "parameters": params, "units": model.units, "annotations": anns, "start": model.start_time,
            "stop": model.stop_time, "settings": repr(model.settings), "structure": model.structure}


def _from_extraction(path: Path, reuse_structure: bool):
    """What a run takes from the archive on disk unpacked, as ``cosim-master run`` on a user's archive reads it."""
    folder = archive._extract_ssp(path)
    try:
        return _model_facts(read_ssd(folder / archive.SSD_NAME, folder, shown_root=str(path),
                                     reuse_structure=reuse_structure))
    finally:
        import shutil
        shutil.rmtree(folder)


def _from_memory(path: Path, reuse_structure: bool):
    src = open_scenario(path, in_memory=True)
    assert src.memory is not None and src.tempdir is None
    return read_ssd(src.ssd_path, src.root, shown_root=src.shown_root, reuse_structure=reuse_structure,
                    memory=src.memory)


@pytest.mark.parametrize("reuse_structure", [False, True])
def test_an_archive_read_from_memory_parses_as_its_extraction(tmp_path, fmus, reuse_structure):
    path = tmp_path / "run" / "scenario.ssp"
    for k in (2.0, 3.0, -0.0):                      # the second and third read a structure known before
        _chain(fmus, k, label=f"run with k={k}\nand a newline").write(path, to_disk=False)
        assert not path.exists()
        memory = _model_facts(_from_memory(path, reuse_structure))
        _chain(fmus, k, label=f"run with k={k}\nand a newline").write(path)      # the same archive, on disk
        archive._WRITTEN.clear()
        assert memory == _from_extraction(path, reuse_structure)
        gain = [p for p in memory["parameters"] if p[:2] == ("gain", "k")]
        assert len(gain) == 1 and gain[0][3] == k and gain[0][4].startswith(f"{path}/SystemStructure.ssd:")
        path.unlink()


def test_an_archive_in_memory_has_the_bytes_and_hash_of_the_one_on_disk(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    _chain(fmus).write(path, to_disk=False)
    assert archive.written_here(path) and not path.exists()
    in_memory = archive.file_sha256(path)
    _chain(fmus).write(path)
    assert hashlib.sha256(path.read_bytes()).hexdigest() == in_memory == archive.file_sha256(path)
    archive._WRITTEN.clear()
    assert archive.file_sha256(path) == in_memory and not archive.written_here(path)


def test_a_file_put_where_the_archive_was_kept_in_memory_is_read_instead(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    _chain(fmus, 2.0).write(path, to_disk=False)
    other = tmp_path / "other.ssp"
    _chain(fmus, 7.0).write(other)
    os.replace(other, path)                        # another archive (written by another process, say)
    archive._WRITTEN.pop(os.path.abspath(other))
    assert not archive.written_here(path)
    model = _from_extraction(path, False)
    assert ("gain", "k", "Real", 7.0) in [p[:4] for p in model["parameters"]]
    src = open_scenario(path, in_memory=True)
    try:
        assert src.memory is None                  # unpacked, as any archive
        assert ("gain", "k", "Real", 7.0) in [(p.component, p.variable, p.type, p.value)
                                              for p in read_ssd(src.ssd_path, src.root, src.shown_root).parameters]
    finally:
        src.close()


def test_writing_to_disk_is_not_skipped_over_an_existing_file(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    path.write_bytes(b"an older file")
    _chain(fmus).write(path, to_disk=False)
    assert zipfile.ZipFile(path).read(archive.SSD_NAME).startswith(b"<?xml")


def test_messages_name_the_archive_as_the_extraction_does(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    _chain(fmus, wrong_connector=True).write(path, to_disk=False)
    with pytest.raises(ScenarioError) as from_memory:
        _from_memory(path, False)
    _chain(fmus, wrong_connector=True).write(path)
    with pytest.raises(ScenarioError) as unpacked:
        _from_extraction(path, False)
    assert str(from_memory.value) == str(unpacked.value)
    assert str(from_memory.value).startswith(f"{path}/SystemStructure.ssd:")
    assert "has no connector 'nope'" in str(from_memory.value)


def test_an_fmu_not_in_the_archive_is_not_found_in_memory_either(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    _chain(fmus).write(path, to_disk=False)
    w = archive._written(path)
    w.files[archive.SSD_NAME] = w.files[archive.SSD_NAME].replace(b'source="resources/Gain.fmu"',
                                                                  b'source="resources/Gone.fmu"', 1)
    with pytest.raises(ScenarioError, match=r"scenario\.ssp/SystemStructure\.ssd:\d+: Component gain: "
                                            r"FMU 'resources/Gone.fmu' not found in the scenario"):
        _from_memory(path, False)


def test_a_run_from_memory_is_the_run_from_disk(tmp_path, fmus):
    path = tmp_path / "a" / "scenario.ssp"
    _chain(fmus).write(path, to_disk=False)
    ours = master.run(path, output=str(tmp_path / "out_a"), raise_on_error=False, reuse_structure=True)
    assert not path.exists() and not list(Path(os.environ["COSIM_MASTER_CACHE"]).rglob("cosim-ssp-*"))
    disk = tmp_path / "b" / "scenario.ssp"
    _chain(fmus).write(disk)
    archive._WRITTEN.clear()                       # read as a user's archive: unpacked
    theirs = master.run(disk, output=str(tmp_path / "out_b"), raise_on_error=False)
    assert ours.metadata["outcome"] == theirs.metadata["outcome"] == "completed"
    assert ours.metadata["scenario_sha256"] == theirs.metadata["scenario_sha256"]
    for name in ("results.csv",):
        assert (tmp_path / "out_a" / name).read_bytes() == (tmp_path / "out_b" / name).read_bytes()


def test_a_campaign_run_writes_its_archive_only_where_the_folder_keeps_it(tmp_path):
    from master.campaign.execute import kept_after_run
    from uavstudy.build import build_scenario
    from uavstudy.campaign_kind import UAV_KIND
    base = Path(__file__).resolve().parents[3] / "ssp" / "scenarios" / "paper_area.yaml"
    task = {"scenario": str(base), "overrides": {"n_uavs": 2, "stop_time": 5.0}, "seed": 11, "campaign": "c",
            "run_id": "r", "rep": 0, "campaign_seed": 1, "params": {"n_uavs": 2}, "inputs": {"scenario": "x"}}
    assert not kept_after_run({**task, "keep": "summary"}, "scenario.ssp", UAV_KIND)
    assert kept_after_run({**task, "keep": "summary"}, "scenario.yaml", UAV_KIND)
    for keep in ("summary", "all"):
        out = tmp_path / keep
        out.mkdir()
        run = UAV_KIND.prepare_run({**task, "keep": keep}, out, {})
        assert run.scenario == out / "scenario.ssp" and archive.written_here(run.scenario)
        assert run.scenario.exists() == (keep == "all")
        # the archive a user keeps, or would have kept: the one built afresh from the run's scenario.yaml
        fresh = build_scenario(out / "scenario.yaml", tmp_path / f"{keep}.ssp")
        assert archive.file_sha256(run.scenario) == hashlib.sha256(fresh.read_bytes()).hexdigest()
        if keep == "all":
            assert run.scenario.read_bytes() == fresh.read_bytes()


# ------------------------------------------------------------------------ the archive's bytes without zipfile
def _by_zipfile(members) -> bytes:
    buf = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")             # duplicate names: zipfile writes them, and so must we
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as zf:
            for name, data in members:
                zf.writestr(writer._zinfo(name), data)
    return buf.getvalue()


def test_the_archive_pieces_are_the_bytes_zipfile_writes():
    rng = random.Random(7)
    names = ["SystemStructure.ssd", "resources/M.fmu", "resources/a b.ssv", "x/y/z.fmu", "é.fmu", "d/"]
    for _ in range(300):
        members = [(rng.choice(names), rng.randbytes(rng.choice([0, 1, 57, 70_000])))
                   for _ in range(rng.randint(1, 6))]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")         # names zipfile writes itself (non-ASCII, folders), duplicates
            pieces = writer._archive_chunks([(n, d, zlib.crc32(d)) for n, d in members])
        assert b"".join(pieces) == _by_zipfile(members)


# ---------------------------------------------------------------------------- scenario.yaml item by item
_TEXT = string.ascii_letters + " \n\t:-#'\"|>&*!%@`,[]{}é\u2028~?0123456789."


def _random_value(rng, depth=0):
    r = rng.random()
    if depth > 3 or r < 0.5:
        return rng.choice([None, True, False, rng.randint(-10**12, 10**12), rng.uniform(-1e6, 1e6), float("nan"),
                           -0.0, 1e-300, "", "yes", "null", "1.0", " a ", _random_text(rng)])
    if r < 0.75:
        return [_random_value(rng, depth + 1) for _ in range(rng.randint(0, 5))]
    return {_random_text(rng) or "k": _random_value(rng, depth + 1) for _ in range(rng.randint(0, 4))}


def _random_text(rng):
    return "".join(rng.choice(_TEXT) for _ in range(rng.choice([0, 1, 4, 30, 150])))


def test_scenario_yaml_item_by_item_is_the_whole_dump():
    from uavstudy.campaign_kind import dump_scenario
    rng = random.Random(3)
    shared_seen = 0
    for i in range(2000):
        data = {_random_text(rng) or f"k{i}": _random_value(rng) for _ in range(rng.randint(1, 7))}
        keys = list(data)
        if rng.random() < 0.15 and len(keys) > 1:   # one list under two items: YAML writes an anchor
            shared = [1, [2]]
            data[keys[0]], data[keys[-1]] = shared, {"again": shared}
            shared_seen += 1
        whole = yamlio.dump(data, sort_keys=False, default_flow_style=None)
        assert dump_scenario(data) == whole
        assert dump_scenario(pickle.loads(pickle.dumps(data))) == whole      # the items from the cache
    assert shared_seen > 100


# ------------------------------------------------------------------------------- the structure key by shape
def test_ssds_of_one_written_shape_have_one_structure_key(tmp_path, fmus):
    path = tmp_path / "scenario.ssp"
    shapes = {}
    for k, label in ((2.0, "a"), (3.5, "b\nc\r\td" * 40), (-1e300, "")):
        _chain(fmus, k, label).write(path, to_disk=False)
        w = archive._written(path)
        top = parser.xsd.parse_xml(path / archive.SSD_NAME, data=w.files[archive.SSD_NAME]).getroot()
        shapes.setdefault(w.shape, set()).add(structure_key(top))
        assert parser._structure_key(top, archive._from_memory(path, w).memory) == structure_key(top)
    assert len(shapes) == 1 and None not in shapes and all(len(keys) == 1 for keys in shapes.values())
    _chain(fmus, wrong_connector=True).write(path, to_disk=False)         # another shape: another number
    assert archive._written(path).shape not in shapes
