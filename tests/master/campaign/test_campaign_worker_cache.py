"""What a campaign worker keeps between runs (parsed base scenarios, random layouts, FMU bytes, FMU members of
run archives linked to one stored copy) changes nothing a run produces, and is keyed by what it depends on.

The expectation of the first test is the fresh path: the same run in a new Python process, where nothing is
cached, must write the same files bit for bit as the run made by a worker that ran other runs before it.
"""
import hashlib
import json
import os
import subprocess
import sys
import zipfile
from dataclasses import replace
from pathlib import Path

import pytest

from master.campaign.execute import execute_run
from master.campaign.runner import make_task
from master.campaign.spec import load_campaign
from master.observers import recording
from master.ssp import archive
from master.ssp.archive import open_scenario
from master.ssp.writer import SspBuilder
from uavstudy import build, campaign_kind
from uavstudy.build import FMU_FILES, default_fmu_dir, layout_key
from uavstudy.scenario import load_scenario_yaml
from uavsim.strategy import ZoneMap

ROOT = Path(__file__).resolve().parents[3]

pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMU_FILES.values()),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")

# the paper campaign's grid on a short flight, so that the test takes seconds
CAMPAIGN = f"""\
name: cache-check
seed: 2021
repetitions: 2
grid:
  strategy: [A, B]
  n_uavs: [1, 2]
  variant:
    free: {ROOT / 'ssp' / 'scenarios' / 'paper_area.yaml'}
    zones: {ROOT / 'ssp' / 'scenarios' / 'paper_area_zones.yaml'}
  wind.probability: 0.15
  rules: paper
  layout: random
run:
  step: 0.5
  stop_time: 120
  record_interval: 5
  csv: false
keep: summary
"""
COMPARED = ("summary.json", "summary.csv", "photos.csv", "events.csv", "scenario.yaml")
# how the run was executed and filed, not what it computed (bench/compare_runs.py's list, plus the folders)
VOLATILE = {"wall_time_s", "finished_at", "worker", "scenario", "platform", "python", "package_version", "used",
            "traceback", "timing", "native_loop", "out_dir"}

FRESH = """
import json, sys
from master.campaign.execute import execute_run
task = json.loads(sys.argv[1])
rec = execute_run(task)
print(json.dumps(rec))
"""


def _clean(o):
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items() if k not in VOLATILE}
    if isinstance(o, list):
        return [_clean(v) for v in o]
    return o


def _files(folder: Path) -> dict:
    out = {name: (folder / name).read_bytes() for name in COMPARED if (folder / name).is_file()}
    out["run.json"] = _clean(json.loads((folder / "run.json").read_text()))
    return out


def test_a_worker_that_ran_other_runs_writes_what_a_fresh_process_writes(tmp_path):
    build._LAYOUTS.clear()          # this process may have run other tests' campaigns
    campaign_kind._BASES.clear()
    ZoneMap._BUILT.clear()
    recording._MATCHED.clear()
    archive._WRITTEN.clear()
    path = tmp_path / "camp.yaml"
    path.write_text(CAMPAIGN)
    camp = load_campaign(path)
    def pick(strategy, n, variant):
        return next(r for r in camp.runs if r.rep == 1 and r.params["strategy"] == strategy
                    and r.params["n_uavs"] == n and r.params["variant"] == variant)
    target = pick("B", 2, "zones")
    # the worker first runs other runs: the other area's base file, the same area and layout with the other
    # strategy (its layout is the one the target reuses), another fleet size
    before = [pick("A", 1, "free"), pick("A", 2, "zones"), pick("B", 1, "zones")]
    warm_out = tmp_path / "warm"
    for r in before:
        assert execute_run(make_task(camp, r, warm_out))["outcome"] == "completed"
    assert len(build._LAYOUTS) == 3 and len(campaign_kind._BASES) == 2     # what the target run finds
    # ... and the zone maps of the zones runs' areas, the record selections, the archives written
    assert ZoneMap._BUILT and recording._MATCHED and len(archive._WRITTEN) == 3
    warm = execute_run(make_task(camp, target, warm_out))
    assert warm["outcome"] == "completed"

    fresh_out = tmp_path / "fresh"
    env = dict(os.environ, COSIM_MASTER_CACHE=str(tmp_path / "fresh-cache"))     # no stored FMU copy either
    proc = subprocess.run([sys.executable, "-c", FRESH, json.dumps(make_task(camp, target, fresh_out))],
                          capture_output=True, text=True, env=env, check=True, cwd=ROOT)
    fresh = json.loads(proc.stdout.strip().splitlines()[-1])

    assert _clean(warm) == _clean(fresh)
    a = _files(warm_out / "runs" / target.run_id)
    b = _files(fresh_out / "runs" / target.run_id)
    assert set(a) == set(b) and {"summary.json", "photos.csv", "scenario.yaml"} <= set(a)
    for name in a:
        assert a[name] == b[name], name
    # the flight was long enough to mean something: the UAVs took photos
    assert json.loads(a["summary.json"])["total"]["photos_sum"] > 0


def test_the_layout_key_changes_with_what_draws_the_layout(tmp_path):
    base = load_scenario_yaml(ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml")
    assert layout_key(base) is None          # the shipped area is fixed: nothing to reuse
    rnd = replace(base, layout="random", layout_seed=7)
    key = layout_key(rnd)
    for change in ({"layout_seed": 8}, {"n_uavs": rnd.n_uavs + 1}, {"area_scale": 2.0},
                   {"targets": rnd.targets[:-1]}, {"zones": rnd.zones[:-1]}):
        assert layout_key(replace(rnd, **change)) != key, change
    # what the layout does not read leaves the key alone
    assert layout_key(replace(rnd, strategy="B", seed=99)) == key


def _fmu_archive(path: Path, payload: bytes) -> Path:
    """A zip named .fmu whose only content is ``payload`` (only bytes matter to the archive writer)."""
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("modelDescription.xml", payload)
    return path


def _member(ssp: Path, name: str) -> bytes:
    with zipfile.ZipFile(ssp) as zf:
        return zf.read(name)


def test_a_changed_fmu_reaches_the_next_archive_and_its_unpacked_copy(tmp_path, monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    fmu = _fmu_archive(tmp_path / "M.fmu", b"first")
    shown = []
    for payload, run in ((b"first", 1), (b"second version", 2)):
        if run == 2:
            _fmu_archive(fmu, payload)
            st = fmu.stat()
            os.utime(fmu, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))   # a rewrite within the same tick
        b = SspBuilder("m")
        b.add_component("m", fmu, connectors=[("u", "input", "Real", None)])
        ssp = b.write(tmp_path / f"run{run}.ssp")
        member = _member(ssp, "resources/M.fmu")
        assert member == fmu.read_bytes()
        src = open_scenario(ssp)
        try:
            unpacked = src.root / "resources" / "M.fmu"
            # the unpacked member is the archive's bytes, stored once under their own SHA-256
            assert unpacked.read_bytes() == member
            assert unpacked.resolve().name == f"{hashlib.sha256(member).hexdigest()}.fmu"
            shown.append(unpacked.resolve())
        finally:
            src.close()
        assert shown[-1].is_file()           # closing the scenario removes its folder, not the stored copy
    assert shown[0] != shown[1]


def test_an_unpacked_fmu_cannot_be_written_through_into_the_store(tmp_path, monkeypatch):
    """A member named twice is extracted over the first one's place: the stored copy stays as it was."""
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(tmp_path / "cache"))
    ssp = tmp_path / "twice.ssp"
    with zipfile.ZipFile(ssp, "w") as zf, pytest.warns(UserWarning, match="Duplicate name"):
        zf.writestr("SystemStructure.ssd", b"<x/>")
        zf.writestr("resources/A.fmu", b"one")
        zf.writestr("resources/A.fmu", b"two")
    src = open_scenario(ssp)
    try:
        assert (src.root / "resources" / "A.fmu").read_bytes() == b"two"   # the later one, as zipfile does
    finally:
        src.close()
    stored = {p.read_bytes() for p in (tmp_path / "cache" / "archived").glob("*.fmu")}
    assert stored == {b"one", b"two"}
