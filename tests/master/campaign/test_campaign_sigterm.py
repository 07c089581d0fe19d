"""SIGTERM to ``cosim-master campaign`` (as ``timeout``, systemd or ``kill`` send it) stops it as Ctrl-C does: the
complete records kept, a last line saying what happened, exit 143 as run (docs/campaigns.md). It used to die with no
message."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import program_server
from campaign_helpers import write_chain_ssp
from test_campaign_run import SLOW, write_campaign

ROOT = Path(__file__).resolve().parents[3]


def test_sigterm_keeps_only_complete_records_and_says_so(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path, SLOW)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = program_server.Popen([sys.executable, "-m", "master.cli", "campaign", str(camp), "-o", str(out),
                              "--workers", "1", "--no-progress"], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, default_signals={signal.SIGTERM})
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list((out / "runs").glob("*.json"))) < 2 and p.poll() is None:
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    stdout, stderr = p.communicate(timeout=120)
    assert p.returncode == 143, (stdout, stderr)
    assert "Interrupted" in stdout or "stopped by SIGTERM" in stderr, (stdout, stderr)
    records = list((out / "runs").glob("*.json"))
    assert 2 <= len(records) < 12
    for r in records:
        assert json.loads(r.read_text())["outcome"] == "completed"


def _state(pid: int) -> str | None:
    """The process's state letter (Z: exited, not reaped yet), or None when it is gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def _ppid(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if int((d / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                    out.append(int(d.name))
            except (OSError, IndexError, ValueError):
                pass
    return out


def test_a_killed_campaign_leaves_no_worker_behind(tmp_path, chain_fmus):
    """kill -9 of the campaign process (it can do nothing about it) during a run of an hour: its worker, forked by
    the fork server, dies with the server (PR_SET_PDEATHSIG), which exits with the campaign process, instead of
    finishing its run."""
    if not Path("/proc/self/stat").exists():
        pytest.skip("reads /proc")
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path, SLOW.replace("[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]", "[1]")
                          .replace("stop_time: 0.5", "stop_time: 3600.0"))
    out = tmp_path / "out"
    p = program_server.Popen([sys.executable, "-m", "master.cli", "campaign", str(camp), "-o", str(out),
                              "--workers", "1", "--no-progress"], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and p.poll() is None and not [d for d in (out / "runs").glob("*")
                                                                         if d.is_dir()]:
            time.sleep(0.05)        # the worker has created its run's folder: it runs
        workers = [w for s in _children(p.pid) for w in _children(s)]      # forked by the fork server
        assert len(workers) == 1, workers
        worker, server = workers[0], _ppid(workers[0])
    finally:
        p.kill()
        p.wait(10)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and (_state(worker) not in (None, "Z") or _state(server) not in (None, "Z")):
        time.sleep(0.05)
    assert _state(worker) in (None, "Z") and _state(server) in (None, "Z")
