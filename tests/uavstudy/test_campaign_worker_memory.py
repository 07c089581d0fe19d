"""A campaign worker keeps nothing of a finished run: runs of strategy C executed one after another in one process,
as a pool worker executes them (``execute_run``), leave as many live objects as the first ones left.

The comm monitor's table of running systems once kept every finished C run alive (its context, buffers, plan and
outputs: ~8 MB a run), and a worker of the 4160-run cooperative campaign grew until the kernel killed it.
tests/uavstudy/test_comm_monitor_lifetime.py checks that monitor alone; this checks a whole campaign run as a worker
runs it, so a run kept alive by any other table fails here too. Counted in objects the garbage collector tracks (a
run's context alone holds thousands), not in resident memory, which the allocator keeps for reuse.
"""
import gc
from pathlib import Path

import pytest

from master.campaign.execute import execute_run
from master.campaign.runner import make_task
from master.campaign.spec import load_campaign
from uavstudy.build import CHANNEL_FMU, FMU_FILES, default_fmu_dir

pytestmark = pytest.mark.skipif(
    not all((default_fmu_dir() / f).is_file() for f in [*FMU_FILES.values(), CHANNEL_FMU]),
    reason="UAV FMUs not built (python fmu_sources/build_fmus.py)")

ROOT = Path(__file__).resolve().parents[2]

CAMPAIGN = f"""\
name: worker-memory
seed: 7
repetitions: 6
scenario: {ROOT / 'ssp' / 'scenarios' / 'paper_area_zones.yaml'}
grid:
  strategy: C
  n_uavs: 2
  wind.probability: 0.1
  comm.range: 50.0
  comm.loss: 0.5
run:
  step: 0.5
  stop_time: 20
  record_interval: 5
  csv: false
keep: summary
"""


def _live_objects() -> int:
    gc.collect()
    return len(gc.get_objects())


def test_a_worker_running_c_runs_does_not_grow(tmp_path):
    path = tmp_path / "campaign.yaml"
    path.write_text(CAMPAIGN)
    camp = load_campaign(path)
    tasks = [make_task(camp, r, tmp_path / "out") for r in camp.runs]     # the same cell, other seeds (wind)
    counts = []
    for task in tasks:
        rec = execute_run(task)
        assert rec["outcome"] == "completed", rec.get("error")
        counts.append(_live_objects())
    # the first runs fill the process's caches (imports, FMU classes, the structure of the SSD); after them a run
    # that kept itself alive would add its thousands of objects each time
    growth = (counts[-1] - counts[2]) / (len(counts) - 3)
    assert growth < 100, counts         # 1 a run; with the comm monitor's leak about 6700
