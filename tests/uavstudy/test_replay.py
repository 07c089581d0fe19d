"""replay.html: what the page holds (against the run's own CSV files), that a run and ``cosim-master replay`` write
the same page, the sampling rule of large runs, and the CLI's one-line errors.  The page in a real browser:
test_replay_browser.py."""
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from master.cli import main
from master.runner import run
from uavstudy.replay import REPLAY_FILE, SCALES, _kept_rows, encode_tracks

ROOT = Path(__file__).resolve().parents[2]
SSP = ROOT / "ssp" / "paper_zones_4uav_A.ssp"      # 4 UAVs, two collisions, ends by itself at t = 34.8 s


@pytest.fixture(scope="module")
def collision_run(tmp_path_factory):
    return run(SSP, output=tmp_path_factory.mktemp("replay") / "run")


def page_data(path: Path) -> dict:
    text = path.read_text(encoding="utf-8")
    m = re.search(r'<script id="replay-data" type="application/json">(.*?)</script>', text, re.S)
    return json.loads(m.group(1).replace("<\\/", "</"))


def undelta(a, scale):
    return np.cumsum(np.asarray(a, dtype=float)) / scale


def test_the_page_holds_every_trajectory_row_and_every_event(collision_run):
    out = collision_run.output_dir
    d = page_data(out / REPLAY_FILE)
    traj = pd.read_csv(out / "trajectory.csv")
    assert d["sampling"]["stride"] == 1 and [u["name"] for u in d["uavs"]] == ["uav1", "uav2", "uav3", "uav4"]
    for u, tr in zip(d["uavs"], d["tracks"]):
        rows = traj[traj["uav"] == u["name"]]
        assert tr["n"] == len(rows)
        for col in ("x", "y", "z", "speed", "soc"):      # rounded to the stated resolution, nothing else
            assert np.abs(undelta(tr[col], SCALES[col]) - rows[col].to_numpy()).max() <= 0.5 / SCALES[col] + 1e-9
        assert np.abs(undelta(tr["t"], SCALES["t"]) - rows["time"].to_numpy()).max() <= 0.0005 + 1e-9
        phases = [d["phases"][c] for _, c in tr["phase"]]
        assert phases == [p for i, p in enumerate(rows["phase"]) if i == 0 or p != rows["phase"].iloc[i - 1]]
    # every event, exact, and the ones that ended two UAVs' missions each
    ev = pd.read_csv(out / "events.csv")
    assert [e[0] for e in d["events"]] == ev["time"].tolist()
    collisions = [e for e in d["events"] if e[1] == "uav"]
    assert [(c[0], d["uavs"][c[3]]["name"], c[4]) for c in collisions] == \
        [(r.time, r.uav, r.other) for r in ev[ev["type"] == "uav"].itertuples()]
    assert [d["tracks"][k]["removed"] for k in range(4)] == [True, True, True, True]
    assert {u["name"]: u["outcome"] for u in d["uavs"]} == \
        {u: "uav_collision" for u in ("uav1", "uav2", "uav3", "uav4")}
    assert all(u["vehicle"] == "point-mass" for u in d["uavs"])


def test_the_page_loads_nothing_from_outside(collision_run):
    text = (collision_run.output_dir / REPLAY_FILE).read_text(encoding="utf-8")
    assert not re.search(r"<(link|img|iframe)\b", text, re.I)
    assert not re.search(r"<script[^>]*\bsrc=", text, re.I)
    assert not re.search(r"(https?:)?//[a-z0-9.-]+\.[a-z]{2,}/", text, re.I)
    assert "@import" not in text and "url(" not in text and "fetch(" not in text and "XMLHttpRequest" not in text


def test_replay_command_writes_the_page_the_run_wrote(collision_run, tmp_path, capsys):
    """One page for one run: from the run's memory or from its folder's files, the same bytes."""
    copy = tmp_path / "copy"
    shutil.copytree(collision_run.output_dir, copy)
    written = (copy / REPLAY_FILE).read_bytes()
    (copy / REPLAY_FILE).unlink()
    assert main(["replay", str(copy), "--scenario", str(SSP)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {copy / REPLAY_FILE}"
    assert (copy / REPLAY_FILE).read_bytes() == written


def test_replay_command_finds_the_scenario_run_json_names(collision_run, tmp_path, monkeypatch):
    copy = tmp_path / "copy"
    shutil.copytree(collision_run.output_dir, copy)
    meta = json.loads((copy / "run.json").read_text())
    meta["scenario"] = str(SSP.relative_to(ROOT))         # as `cosim-master run ssp/...` from the checkout writes it
    (copy / "run.json").write_text(json.dumps(meta))
    monkeypatch.chdir(ROOT)
    assert main(["replay", str(copy)]) == 0
    monkeypatch.chdir(tmp_path)                          # elsewhere: not found, and said so in one line
    assert main(["replay", str(copy)]) == 1
    # a run folder inside the folder the run was started from (results/x of a checkout), named from elsewhere
    checkout = tmp_path / "checkout"
    (checkout / "ssp").mkdir(parents=True)
    shutil.copy(SSP, checkout / meta["scenario"])
    shutil.copytree(copy, checkout / "results" / "x")
    assert main(["replay", str(checkout / "results" / "x")]) == 0


def test_replay_command_errors_are_one_line(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "missing")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("cosim-master: error: ") and "run.json" in err and "\n" not in err
    # a run no study's monitor observed: no scenario kind claims it
    (tmp_path / "ssp_run").mkdir()
    (tmp_path / "ssp_run" / "run.json").write_text(json.dumps({"scenario": "a.ssp", "outcome": "completed"}))
    assert main(["replay", str(tmp_path / "ssp_run")]) == 1
    err = capsys.readouterr().err.strip()
    assert "no scenario kind claims this run" in err and "\n" not in err
    # a UAV run that kept its summary only (a campaign's keep: summary)
    (tmp_path / "summary_only").mkdir()
    (tmp_path / "summary_only" / "run.json").write_text(json.dumps(
        {"scenario": "a.ssp", "monitors": {"org.cosim-master.uav-monitor": {}}}))
    assert main(["replay", str(tmp_path / "summary_only")]) == 1
    err = capsys.readouterr().err.strip()
    assert "has no trajectory.csv" in err and "\n" not in err


def test_large_runs_keep_every_kth_row_and_every_change():
    """The stated rule: stride k = ceil(rows / budget); each UAV keeps rows 0, k, 2k, ..., its last row, and each
    row where its phase or mission state changes."""
    n = 1000
    t = np.arange(n, dtype=float)
    phase = np.array(["fly"] * 333 + ["land"] * 10 + ["landed"] * (n - 343), dtype=object)
    state = np.array(["transit"] * 500 + ["landing"] * (n - 500), dtype=object)
    traj = pd.DataFrame({"time": np.concatenate([t, t]), "uav": ["a"] * n + ["b"] * n,
                         "x": np.concatenate([t, -t]), "y": 0.0, "z": 20.0, "speed": 1.0, "soc": 0.5,
                         "phase": np.concatenate([phase, phase]), "mission_state": np.concatenate([state, state]),
                         "status": "active"})
    tracks, tables, stride = encode_tracks(traj, ["a", "b"], budget=300)
    assert stride == 7                                   # ceil(2000 / 300)
    expect = sorted(set(range(0, n, 7)) | {n - 1, 333, 343, 500})
    assert _kept_rows(n, 7, phase, state).tolist() == expect
    for sign, tr in zip((1, -1), tracks):
        assert tr["n"] == len(expect)
        assert undelta(tr["t"], SCALES["t"]).tolist() == [float(i) for i in expect]
        assert undelta(tr["x"], SCALES["x"]).tolist() == [sign * float(i) for i in expect]
        assert [(i, tables["phases"][c]) for i, c in tr["phase"]] == \
            [(0, "fly"), (expect.index(333), "land"), (expect.index(343), "landed")]
    assert encode_tracks(traj, ["a", "b"], budget=2 * n)[2] == 1      # within the budget: every row


def test_campaign_runs_keep_their_replay_and_the_report_links_it(tmp_path):
    from master.campaign.report import build_report
    from master.campaign.runner import run_campaign
    camp = tmp_path / "c.yaml"
    camp.write_text(f"""\
name: replay-tiny
seed: 4
scenario: {ROOT / 'ssp' / 'scenarios' / 'paper_area.yaml'}
grid:
  strategy: [A, B]
  n_uavs: 2
run:
  step: 0.5
  stop_time: 30
  record_interval: 5
  csv: false
keep: all
""")
    out = tmp_path / "out"
    assert run_campaign(camp, output=out, workers=1, progress=False).completed == 2
    runs = sorted(p for p in (out / "runs").iterdir() if p.is_dir())
    assert all((r / REPLAY_FILE).is_file() for r in runs)
    report = build_report(out).read_text()
    links = re.findall(r"\[replay\.html\]\((\.\./runs/[0-9a-f]+/replay\.html)\)", report)
    assert sorted((out / "report" / link).resolve() for link in links) == [r / REPLAY_FILE for r in runs]
    # the replay command finds a campaign run's own scenario.ssp
    page = (runs[0] / REPLAY_FILE).read_bytes()
    assert main(["replay", str(runs[0])]) == 0 and (runs[0] / REPLAY_FILE).read_bytes() == page


def test_sitl_and_point_mass_vehicles_are_told_apart(tmp_path):
    """The vehicle of each UAV comes from the FMU its dynamics component loads (UavSitl.fmu: SITL)."""
    import yaml

    from uavstudy.build import build_scenario
    from uavstudy.replay import scene_from_ssp
    data = yaml.safe_load((ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml").read_text())
    data["vehicle"] = ["sitl", "point_mass", "sitl", "point_mass"]
    (tmp_path / "mixed.yaml").write_text(yaml.safe_dump(data))
    ssp = build_scenario(tmp_path / "mixed.yaml", tmp_path / "mixed.ssp")
    scene = scene_from_ssp(ssp)
    assert [(u["name"], u["vehicle"]) for u in scene.uavs] == \
        [("uav1", "sitl"), ("uav2", "point-mass"), ("uav3", "sitl"), ("uav4", "point-mass")]
    assert len(scene.targets) == 24 and [z["name"] for z in scene.zones][:1] == ["zone_southeast"]


def test_a_missing_value_is_null_and_the_series_goes_on_from_the_last_one():
    from uavstudy.replay import _deltas
    assert _deltas(np.array([1.0, np.nan, 1.5, 1.25]), 100.0) == [100, None, 50, -25]
    assert _deltas(np.array([np.nan, np.nan]), 100.0) == []          # no value at all: no series
    assert _deltas(np.array([0.123456, -0.004]), 100.0) == [12, -12]
