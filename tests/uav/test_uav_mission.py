"""End-to-end tests of the UAV study: build-scenario -> SSP -> run with the UAV monitor -> outputs."""
import json
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from lxml import etree

from master.cli import main
from master.runner import run
from master.ssp import xsd
from uavstudy.build import build_from_paper_config, build_scenario, default_fmu_dir, pad_positions
from uavsim.geodesy import geodetic_from_enu

ROOT = Path(__file__).resolve().parents[2]
BASE = (-7.275, -35.965, 540.0)
FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu"]

pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")


def latlon(e, n):
    lat, lon, _ = geodetic_from_enu(e, n, 0.0, *BASE)
    return [round(float(lat), 8), round(float(lon), 8)]


def write_yaml(path, **over):
    d = {"name": "short", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 1, "strategy": "B",
         "targets": [latlon(0, 55), latlon(55, 55), latlon(55, 0)], "step": 0.1, "stop_time": 120.0, "seed": 3}
    d.update(over)
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def short_ssp(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("short")
    return build_scenario(write_yaml(tmp / "short.yaml"), tmp / "short.ssp")


@pytest.fixture(scope="module")
def short_run(short_ssp, tmp_path_factory):
    out = tmp_path_factory.mktemp("run1")
    return run(short_ssp, output=out)


# ------------------------------------------------------------------------------ build
def test_build_scenario_cli_validates_and_inspects(tmp_path, capsys):
    y = write_yaml(tmp_path / "s.yaml", n_uavs=3, zones=[{"name": "zz", "polygon": [
        latlon(100, 100), latlon(130, 100), latlon(130, 130), latlon(100, 130)]}])
    out = tmp_path / "s.ssp"
    assert main(["build-scenario", str(y), "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    with zipfile.ZipFile(out) as z:
        names = z.namelist()
        ssd = etree.fromstring(z.read("SystemStructure.ssd"))
    # each FMU once, shared by its instances
    assert sorted(names) == sorted(["SystemStructure.ssd"] + [f"resources/{f}" for f in FMUS])
    xsd.validate(etree.ElementTree(ssd), "ssd", str(out))
    comps = [c.get("name") for c in ssd.iter("{*}Component")]
    assert comps == ["wind"] + [f"uav{i}_{k}" for i in (1, 2, 3) for k in ("dyn", "bat", "strat")]
    # one wind feeds every dynamics
    wind_links = [(c.get("endElement"), c.get("endConnector")) for c in ssd.iter("{*}Connection")
                  if c.get("startElement") == "wind"]
    assert sorted(wind_links) == sorted((f"uav{i}_dyn", f"wind_{a}") for i in (1, 2, 3) for a in "xyz")
    mon = next(ssd.iter("{https://cosim-master.org/ssp/uav}UavMonitor"))
    assert mon.get("impactDiameter") == "2.6"
    assert [u.get("name") for u in mon.iter("{*}Uav")] == ["uav1", "uav2", "uav3"]
    assert [z.get("name") for z in mon.iter("{*}Zone")] == ["zz"]
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "uav3_strat" in text and "wind" in text


def test_build_bad_yaml_one_line_error(tmp_path, capsys):
    y = write_yaml(tmp_path / "bad.yaml", strategy="C")
    assert main(["build-scenario", str(y), "-o", str(tmp_path / "bad.ssp")]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "strategy" in err and "bad.yaml" in err
    assert not (tmp_path / "bad.ssp").exists()


def test_build_from_paper_config(tmp_path):
    p = build_from_paper_config(ROOT / "ssp" / "paper_config", tmp_path / "paper.ssp")
    with zipfile.ZipFile(p) as z:
        ssd = etree.fromstring(z.read("SystemStructure.ssd"))
    assert any(c.get("name") == "uav1_strat" for c in ssd.iter("{*}Component"))


def test_pads_are_apart():
    for n in (1, 2, 3, 4, 8):
        p = np.asarray(pad_positions(n))
        if n > 1:
            d = np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))
            assert d[~np.eye(n, dtype=bool)].min() >= 8.0 - 1e-6


# ------------------------------------------------------------------------------ short mission
def test_short_mission_success(short_run):
    out = short_run.output_dir
    assert short_run.ok
    photos = pd.read_csv(out / "photos.csv")
    assert sorted(photos["target"]) == [0, 1, 2]
    assert list(photos.columns) == ["uav", "target", "time", "x", "y", "lat", "lon"]
    assert photos["time"].is_monotonic_increasing
    summary = json.loads((out / "summary.json").read_text())
    u = summary["uavs"][0]
    assert u["outcome"] == "success" and u["targets_visited"] == 3 and u["photos"] == 3
    assert u["distance_to_home_m"] <= 5.0 and u["remaining_battery_pct"] > 5.0
    assert 200 < u["distance_xy_m"] < 260 and u["flight_time_s"] > 0 and u["energy_used_Wh"] > 0
    assert summary["total"]["mission_success"] is True
    s = pd.read_csv(out / "summary.csv")
    assert list(s["uav"]) == ["uav1", "total"]
    traj = pd.read_csv(out / "trajectory.csv")
    assert {"time", "uav", "lat", "lon", "alt", "x", "y", "z", "speed", "soc", "phase", "mission_state"} <= set(traj)
    assert len(traj) == 121 and traj["time"].iloc[-1] == 120.0
    assert (out / "map.png").stat().st_size > 10_000
    ev = pd.read_csv(out / "events.csv")
    assert list(ev[ev.type == "mission"]["event"])[-1] == "landed_base"
    assert short_run.metadata["monitors"]["org.cosim-master.uav-monitor"]["uavs"] == {"uav1": "success"}


def test_same_seed_same_results(short_ssp, short_run, tmp_path):
    again = run(short_ssp, output=tmp_path / "again")
    a = pd.read_parquet(short_run.output_dir / "results.parquet")
    b = pd.read_parquet(again.output_dir / "results.parquet")
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_other_seed_other_wind(tmp_path):
    ssp = build_scenario(write_yaml(tmp_path / "w.yaml", wind={"probability": 0.5}, stop_time=30.0),
                         tmp_path / "w.ssp")
    r1 = run(ssp, output=tmp_path / "s1", seed=1)
    r2 = run(ssp, output=tmp_path / "s2", seed=2)
    w1 = r1.frame[["wind.wind_x", "wind.wind_y"]].to_numpy()
    w2 = r2.frame[["wind.wind_x", "wind.wind_y"]].to_numpy()
    assert np.abs(w1).max() > 0 and np.abs(w2).max() > 0
    assert not np.array_equal(w1, w2)
    # the wind pushes the UAV: its track differs too
    assert not np.array_equal(r1.frame["uav1_dyn.x"].to_numpy(), r2.frame["uav1_dyn.x"].to_numpy())


# ------------------------------------------------------------------------------ head-on
def test_two_uavs_head_on_collide(tmp_path):
    # pads: uav1 at (0, 4), uav2 at (0, -4); uav1 is given the southern target, uav2 the northern one, so
    # right after take-off they fly head-on along x = 0
    assert pad_positions(2) == [(0.0, 4.0), (0.0, -4.0)]
    y = write_yaml(tmp_path / "h.yaml", name="head_on", n_uavs=2, strategy="A",
                   targets=[latlon(0, -150), latlon(0, 150)], stop_time=40.0)
    out = tmp_path / "out"
    assert main(["build-scenario", str(y), "-o", str(tmp_path / "h.ssp")]) == 0
    assert main(["run", str(tmp_path / "h.ssp"), "-o", str(out), "--no-csv"]) == 0
    ev = pd.read_csv(out / "events.csv")
    hits = ev[ev.type == "uav"]
    assert len(hits) == 1
    assert {hits.iloc[0]["uav"], hits.iloc[0]["other"]} == {"uav1", "uav2"}
    assert abs(hits.iloc[0]["y"]) < 1.0 and hits.iloc[0]["z"] > 15
    summary = json.loads((out / "summary.json").read_text())
    assert [u["outcome"] for u in summary["uavs"]] == ["uav_collision", "uav_collision"]
    assert summary["total"]["uav_collisions"] == 1 and summary["total"]["successes"] == 0
    t_hit = hits.iloc[0]["time"]
    # both removed: they stop stepping, their last state stays
    df = pd.read_parquet(out / "results.parquet")
    after = df[df.time > t_hit + 1]
    for u in ("uav1", "uav2"):
        assert after[f"{u}_dyn.x"].nunique() == 1 and after[f"{u}_dyn.y"].nunique() == 1
    traj = pd.read_csv(out / "trajectory.csv")
    assert list(traj.groupby("uav")["status"].last()) == ["removed", "removed"]
    assert (out / "map.png").is_file()


# ------------------------------------------------------------------------------ shipped archives
def test_shipped_archives_are_fresh(tmp_path):
    """The committed ssp/paper_*.ssp equal a fresh build from ssp/scenarios and fmus/ (else: python ssp/build_all.py)."""
    shipped = sorted((ROOT / "ssp").glob("paper_*.ssp"))
    assert (ROOT / "ssp" / "paper_zones_4uav_B.ssp") in shipped
    import subprocess
    import sys
    subprocess.run([sys.executable, str(ROOT / "ssp" / "build_all.py"), "--all", "--out", str(tmp_path)], check=True,
                   capture_output=True)
    stale = [p.name for p in shipped if p.read_bytes() != (tmp_path / p.name).read_bytes()]
    assert not stale, f"stale SSP archives {stale}: run 'python ssp/build_all.py'"


def test_run_ends_when_the_fleet_has_landed(short_run, tmp_path):
    """end_when_all_landed: the same mission ends at the landing instead of idling to the stop time, and the
    mission summary (targets, photos, distance, outcome) is the one of the full-length run."""
    ssp = build_scenario(write_yaml(tmp_path / "e.yaml", end_when_all_landed=True), tmp_path / "e.ssp")
    r = run(ssp, output=tmp_path / "out")
    ended = r.metadata["ended_early"]
    assert ended["reason"] == "every UAV has landed or been removed" and ended["time"] < 120.0
    full = json.loads((short_run.output_dir / "summary.json").read_text())["uavs"][0]
    early = json.loads((tmp_path / "out" / "summary.json").read_text())["uavs"][0]
    for key in ("outcome", "targets_visited", "photos", "distance_m", "flight_time_s"):
        assert early[key] == full[key], key
    # the landing happened inside the step the run ended with
    states = pd.read_csv(tmp_path / "out" / "events.csv")
    landed = states[states["event"] == "landed_base"]["time"]
    assert len(landed) == 1 and landed.iloc[0] <= ended["time"] + 1e-9
