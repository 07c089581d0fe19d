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

from campaign_helpers import write_chain_ssp
from test_campaign_run import SLOW, write_campaign

ROOT = Path(__file__).resolve().parents[3]


def test_sigterm_keeps_only_complete_records_and_says_so(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path, SLOW)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen([sys.executable, "-m", "master.cli", "campaign", str(camp), "-o", str(out), "--workers",
                          "1", "--no-progress"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL))
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
