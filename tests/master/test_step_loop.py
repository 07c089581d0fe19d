"""The step loop (Execution._steps) as a run shows it: the record grid with a row at the stop time that is not on it,
and a row at the time a monitor ends the run. Its accelerators are checked against it by tests/accelerators/."""
import json
from pathlib import Path

import pandas as pd

import master

ROOT = Path(__file__).resolve().parents[2]


def test_a_row_at_the_stop_time_off_the_record_grid(tmp_path):
    """18 steps, a row every 4 and one after the last step."""
    res = master.run(ROOT / "ssp" / "coupling" / "oscillator_fd.ssp", output=None, stop_time=1.8, step=0.1,
                     record_interval=0.4)
    assert res.metadata["steps_done"] == 18 and "ended_early" not in res.metadata
    assert [round(t, 9) for t in res.frame["time"]] == [0.0, 0.4, 0.8, 1.2, 1.6, 1.8]


def test_a_row_where_a_monitor_ends_the_run(tmp_path):
    """The UAV monitor takes two colliding UAVs out and ends the run between two rows of the record grid: the
    recording takes a row there, and the run's facts say where it ended."""
    out = tmp_path / "run"
    res = master.run(ROOT / "ssp" / "paper_zones_4uav_A.ssp", output=out, stop_time=100.0, step=0.1, record=["*"],
                     record_interval=1.0, products="summary")        # run.json and events.csv; no map
    meta = json.loads((out / "run.json").read_text())
    events = pd.read_csv(out / "events.csv")
    assert (events["type"] == "uav").sum() == 2
    end = meta["ended_early"]["time"]
    assert meta["last_time"] == end and abs(meta["steps_done"] * 0.1 - end) < 1e-9
    times = res.frame["time"].tolist()
    assert times[:3] == [0.0, 1.0, 2.0] and times[-1] == end and times[-2] == int(end)
    assert end != int(end)          # off the record grid
