"""A campaign leaves nothing in the temporary folder, also when a run kills its worker: each worker unpacks the runs'
SSPs into a scratch folder named for its process id, which the pool removes once the worker is gone, dead or alive,
and which the next campaign sweeps when the whole campaign was killed. A worker killed by an FMU's abort() cannot
remove its run's unpacked SSP itself; before this every such run left a `cosim-ssp-*` folder behind for good."""
import os
import subprocess
import sys
from pathlib import Path

import master
import program_server
from campaign_helpers import write_chain_ssp
from master.campaign.pool import WORKER_SCRATCH_PREFIX, sweep_left_worker_scratch

CAMPAIGN = """\
name: scratch
seed: 3
scenario: chain.ssp
grid:
  param:src.mode: [0, 3]           # 3: the FMU calls abort() in doStep, which kills the worker mid-run
run:
  stop_time: 1.0
  step: 0.1
"""


def test_a_crashing_run_leaves_the_temporary_folder_empty(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    (tmp_path / "campaign.yaml").write_text(CAMPAIGN)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]), TMPDIR=str(tmp))
    r = program_server.run([sys.executable, "-m", "master.cli", "campaign", str(tmp_path / "campaign.yaml"),
                            "--output", str(tmp_path / "out"), "--workers", "2", "--no-progress"],
                           capture_output=True, text=True, env=env, timeout=180)
    assert "Traceback" not in r.stderr, r.stderr
    assert "1 completed, 1 failed" in r.stdout + r.stderr, r.stdout + r.stderr
    assert "SIGABRT" in r.stdout + r.stderr        # the worker did die: it could not clean up after itself
    assert sorted(p.name for p in tmp.iterdir()) == []


def test_scratch_of_a_killed_worker_is_swept_and_no_other(tmp_path):
    """A campaign killed with SIGKILL cannot remove its workers' scratch folders (nor can they: they die with it);
    the next campaign removes those named for a process that is gone, and leaves a live process's folder and
    anything not named for a process."""
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()                                 # reaped: its pid names no process (until the kernel reuses it)
    made = {}
    for key, pid in (("gone", gone.pid), ("alive", os.getppid()), ("unnamed", "x")):
        d = tmp_path / f"{WORKER_SCRATCH_PREFIX}{pid}-tag"
        (d / "cosim-ssp-1" / "resources").mkdir(parents=True)
        made[key] = d
    other = tmp_path / "cosim-ssp-unrelated"
    other.mkdir()
    assert sweep_left_worker_scratch(str(tmp_path)) == [made["gone"].name]
    assert not made["gone"].exists()
    assert made["alive"].is_dir() and made["unnamed"].is_dir() and other.is_dir()
