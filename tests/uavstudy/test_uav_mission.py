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
from uav_places import BASE, latlon

ROOT = Path(__file__).resolve().parents[2]
FMUS = ["UavDynamics.fmu", "UavBattery.fmu", "UavStrategy.fmu", "UavWind.fmu"]

pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMUS),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")


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
    y = write_yaml(tmp_path / "bad.yaml", strategy="D")
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
    assert summary["total"]["success"] is True and summary["total"]["uavs_successful"] == 1
    s = pd.read_csv(out / "summary.csv")
    assert list(s["uav"]) == ["uav1", "total"]
    traj = pd.read_csv(out / "trajectory.csv")
    assert {"time", "uav", "lat", "lon", "alt", "x", "y", "z", "speed", "soc", "phase", "mission_state"} <= set(traj)
    # recorded every 1 s up to the landing that ended the run, then the final row
    end = short_run.metadata["ended_early"]["time"]
    assert list(traj["time"].iloc[:-1]) == list(range(int(end) + 1)) and traj["time"].iloc[-1] == pytest.approx(end)
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
    # run on after the collision (not the default), to see the removed UAVs stay where they were hit
    y = write_yaml(tmp_path / "h.yaml", name="head_on", n_uavs=2, strategy="A",
                   targets=[latlon(0, -150), latlon(0, 150)], stop_time=40.0, end_when_all_landed=False)
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
    assert summary["total"]["uav_collisions"] == 1 and summary["total"]["uavs_successful"] == 0
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
    ssp = build_scenario(write_yaml(tmp_path / "e.yaml", end_when_all_landed=False), tmp_path / "e.ssp")
    run(ssp, output=tmp_path / "full")
    ended = short_run.metadata["ended_early"]      # the default (true)
    assert ended["reason"] == "every UAV has landed or been removed" and ended["time"] < 120.0
    full = json.loads((tmp_path / "full" / "summary.json").read_text())["uavs"][0]
    early = json.loads((short_run.output_dir / "summary.json").read_text())["uavs"][0]
    for key in ("outcome", "targets_visited", "photos", "distance_m", "flight_time_s"):
        assert early[key] == full[key], key
    # the landing happened inside the step the run ended with
    states = pd.read_csv(short_run.output_dir / "events.csv")
    landed = states[states["event"] == "landed_base"]["time"]
    assert len(landed) == 1 and landed.iloc[0] <= ended["time"] + 1e-9


# ------------------------------------------------------------------------------ what the outputs say
def test_summary_reports_the_seed_the_run_used(short_ssp, tmp_path):
    """The SSP was built with seed 3; --seed 11 replaces the wind's seed parameter, and the summary says 11."""
    run(short_ssp, output=tmp_path / "s11", seed=11)
    total = json.loads((tmp_path / "s11" / "summary.json").read_text())["total"]
    assert total["scenario_seed"] == 11
    run(short_ssp, output=tmp_path / "s3")
    assert json.loads((tmp_path / "s3" / "summary.json").read_text())["total"]["scenario_seed"] == 3


def test_events_and_trajectory_name_what_happened(short_run):
    """Three targets visited: the return starts after the third photo (not "return_done" before it); the
    trajectory shows phases and mission states by name, from preflight on the pad to landed_base."""
    out = short_run.output_dir
    ev = pd.read_csv(out / "events.csv")
    mission = ev[ev.type == "mission"]
    assert list(mission["event"]) == ["takeoff", "transit", "return_started", "landing", "landed_base"]
    started = mission[mission["event"] == "return_started"].iloc[0]
    assert started["detail"] == "all targets visited, returning to base"
    last_photo = pd.read_csv(out / "photos.csv")["time"].max()
    assert started["time"] >= last_photo
    traj = pd.read_csv(out / "trajectory.csv")
    assert set(traj["phase"]) == {"preflight", "takeoff", "fly", "land", "landed"}
    assert traj["phase"].iloc[0] == "preflight" and traj["phase"].iloc[-1] == "landed"
    assert traj["mission_state"].iloc[0] == "preflight" and traj["mission_state"].iloc[-1] == "landed_base"
    assert "return_started" in set(traj["mission_state"])


def test_summary_total_row_has_one_meaning_per_column(short_ssp, tmp_path):
    """Two UAVs, three targets (equal split: 2 + 1): the total row's success is a boolean like the UAV rows',
    its count of successes, sums and mean battery are in their own columns and agree with the UAV rows."""
    ssp = build_scenario(write_yaml(tmp_path / "two.yaml", n_uavs=2), tmp_path / "two.ssp")
    run(ssp, output=tmp_path / "out")
    s = pd.read_csv(tmp_path / "out" / "summary.csv")
    uavs, total = s[s.uav != "total"], s[s.uav == "total"].iloc[0]
    assert list(uavs["outcome"]) == ["success", "success"] and list(uavs["targets_assigned"]) == [2, 1]
    assert total["success"] == True and total["uavs"] == 2 and total["uavs_successful"] == 2   # noqa: E712
    assert total["targets_assigned"] == 3 and total["targets_visited"] == 3 and total["targets_total"] == 3
    assert total["photos_sum"] == 3 and total["distance_m_sum"] == pytest.approx(uavs["distance_m"].sum())
    assert total["energy_used_Wh_sum"] == pytest.approx(uavs["energy_used_Wh"].sum())
    assert total["remaining_battery_pct_mean"] == pytest.approx(uavs["remaining_battery_pct"].mean())
    # a column the total row does not share with the UAV rows stays empty there, and the reverse
    assert pd.isna(total["outcome"]) and pd.isna(total["distance_m"]) and pd.isna(total["remaining_battery_pct"])
    assert uavs["distance_m_sum"].isna().all() and uavs["uavs_successful"].isna().all()
    doc = json.loads((tmp_path / "out" / "summary.json").read_text())["total"]
    assert "remaining_battery_pct_total" not in doc and "successes" not in doc and "mission_success" not in doc
    assert doc["success"] is True and doc["uavs_successful"] == 2


def test_uav_without_targets_is_not_a_success(tmp_path, caplog):
    """Three UAVs for two targets: the equal split gives one UAV nothing; it takes off, lands again and ends
    as no_targets, not success; build-scenario warns (one line) and still writes the SSP."""
    y = write_yaml(tmp_path / "idle.yaml", n_uavs=3, targets=[latlon(0, 55), latlon(55, 0)])
    with caplog.at_level("WARNING", logger="uavstudy.build"):
        ssp = build_scenario(y, tmp_path / "idle.ssp")
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == 1 and "3 UAVs for 2 targets" in warned[0] and "\n" not in warned[0]
    run(ssp, output=tmp_path / "out")
    doc = json.loads((tmp_path / "out" / "summary.json").read_text())
    by_assigned = {u["targets_assigned"]: u for u in doc["uavs"]}
    assert sorted(u["targets_assigned"] for u in doc["uavs"]) == [0, 1, 1]
    idle = by_assigned[0]
    assert idle["outcome"] == "no_targets" and idle["success"] is False
    assert doc["total"]["uavs_successful"] == 2 and doc["total"]["success"] is False
    assert doc["total"]["outcomes"] == {"success": 2, "no_targets": 1}


def test_build_warns_about_a_target_on_the_base(tmp_path, caplog):
    y = write_yaml(tmp_path / "b.yaml", targets=[latlon(0, 55), latlon(2, 1)])
    with caplog.at_level("WARNING", logger="uavstudy.build"):
        build_scenario(y, tmp_path / "b.ssp")
    assert [r.getMessage() for r in caplog.records] == [
        "warning: scenario short: target(s) [1] lie on the base (within 5 m of the base or a landing pad)"]


def test_shipped_yaml_builds_the_shipped_behaviour(tmp_path):
    """build-scenario on a shipped YAML ends the mission when the fleet has landed, as the shipped SSPs do."""
    def end_when(ssp):
        with zipfile.ZipFile(ssp) as z:
            ssd = etree.fromstring(z.read("SystemStructure.ssd"))
        return next(ssd.iter("{https://cosim-master.org/ssp/uav}UavMonitor")).get("endWhenAllLanded")
    built = build_scenario(ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml", tmp_path / "z.ssp")
    assert end_when(built) == end_when(ROOT / "ssp" / "paper_zones_4uav_B.ssp") == "true"


def test_fleet_all_removed_ends_the_run(tmp_path):
    """Two UAVs collide head-on at t ~ 14 s: nothing is left to fly, the run ends there, not at 40 s."""
    y = write_yaml(tmp_path / "h.yaml", name="head_on", n_uavs=2, strategy="A",
                   targets=[latlon(0, -150), latlon(0, 150)], stop_time=40.0)
    r = run(build_scenario(y, tmp_path / "h.ssp"), output=tmp_path / "out")
    hit = pd.read_csv(tmp_path / "out" / "events.csv").query("type == 'uav'")["time"].iloc[0]
    ended = r.metadata["ended_early"]
    assert ended["reason"] == "every UAV has landed or been removed"
    assert hit <= ended["time"] <= hit + 0.1 + 1e-9      # within the step of the collision (step 0.1 s)
    total = json.loads((tmp_path / "out" / "summary.json").read_text())["total"]
    assert total["mission_end_time"] == pytest.approx(hit)
