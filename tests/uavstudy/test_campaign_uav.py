"""A tiny UAV campaign: YAML overrides and seeds reach the scenario, per-UAV rows, keep: summary."""
import json
from pathlib import Path

import pandas as pd
import pytest
import yaml

from master.campaign.runner import run_campaign
from uavstudy.build import FMU_FILES, default_fmu_dir

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not all((default_fmu_dir() / f).is_file() for f in FMU_FILES.values()),
                                reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")


def test_uav_campaign_rows_overrides_and_keep_summary(tmp_path):
    camp = tmp_path / "uav.yaml"
    camp.write_text(f"""\
name: uav-tiny
seed: 4
scenario: {ROOT / 'ssp' / 'scenarios' / 'paper_area.yaml'}
grid:
  strategy: [A, B]
  n_uavs: 2
  wind.probability: 0.1
runs:
  - {{record: [no_such_variable]}}     # fails when the run starts (a bad scenario value fails the campaign file)
run:
  step: 0.5
  stop_time: 30
  record_interval: 5
  csv: false
keep: summary
""")
    out = tmp_path / "out"
    s = run_campaign(camp, output=out, workers=2, progress=False)
    assert (s.total, s.completed, s.failed) == (3, 2, 1)
    df = pd.read_parquet(out / "results.parquet")
    ok = df[df["run_outcome"] == "completed"]
    assert list(ok["uav"]) == ["uav1", "uav2", "total"] * 2
    assert list(ok["strategy"]) == ["A"] * 3 + ["B"] * 3
    tot = ok[ok["uav"] == "total"]
    assert (tot["wind_probability"] == 0.1).all() and (tot["scenario_seed"] == tot["seed"]).all()
    assert (tot["uavs"] == 2).all() and (tot["summary.strategy"] == tot["strategy"]).all()
    # the total row's own columns: counts, sums and the mean battery; success means all UAVs succeeded
    assert tot["uavs_successful"].between(0, 2).all() and "remaining_battery_pct_total" not in df.columns
    assert (tot["success"].astype(bool) == (tot["uavs_successful"] == 2)).all()
    per_uav = ok[ok["uav"] != "total"]
    assert per_uav["remaining_battery_pct"].between(0, 100).all() and per_uav["distance_m"].notna().all()
    bad = df[df["run_outcome"] == "failed"]
    assert len(bad) == 1 and bad["uav"].isna().all()
    assert bad["error"].iloc[0] == "--record: no variable matches the record patterns ['no_such_variable']"
    for rid in tot["run_id"]:
        files = {p.name for p in (out / "runs" / rid).iterdir()}
        assert {"scenario.yaml", "summary.json", "run.json"} <= files
        assert not files & {"results.parquet", "map.png", "scenario.ssp", "trajectory.csv"}
        scn = yaml.safe_load((out / "runs" / rid / "scenario.yaml").read_text())
        rec = json.loads((out / "runs" / f"{rid}.json").read_text())
        assert scn["seed"] == rec["seed"] and scn["n_uavs"] == 2 and scn["step"] == 0.5 and scn["stop_time"] == 30
        assert scn["wind"]["probability"] == 0.1 and scn["strategy"] == rec["params"]["strategy"]
        assert set(rec["fmus"]) == {"wind", "uav1_dyn", "uav1_bat", "uav1_strat", "uav2_dyn", "uav2_bat", "uav2_strat"}
