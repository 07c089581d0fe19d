"""``cosim-master run --mavlink URL --realtime FACTOR``: pacing and streaming change no result, bad addresses
are one-line errors naming the option, a ground station that goes away costs a warning, and MAVProxy (the
real ground station) sees the fleet."""
from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

import program_server
from cli_in_process import run_cli
from master.errors import CosimError
from master.runner import run
from loopback import free_port

ROOT = Path(__file__).resolve().parents[3]
SSP = ROOT / "ssp" / "paper_zones_4uav_B.ssp"
CLI = [sys.executable, "-m", "master.cli", "run", str(SSP)]


def cli(*args):
    """``cosim-master run SSP ARGS`` in this process (tests/cli_in_process.py): its messages and outputs are checked."""
    return run_cli(["run", str(SSP), *args], cwd=ROOT)


def test_paced_streamed_run_is_bit_identical_to_a_plain_one(tmp_path):
    plain = run(SSP, output=tmp_path / "plain", stop_time=25)
    t0 = time.monotonic()
    live = run(SSP, output=tmp_path / "live", stop_time=25, realtime=100,
               mavlink=[f"udpout:127.0.0.1:{free_port()}"])
    assert time.monotonic() - t0 >= 25 / 100                        # it was paced
    assert live.metadata["observers"]["pacing"]["factor"] == 100
    assert live.metadata["observers"]["mavlink"]["messages_sent"] > 0
    assert pq.read_table(tmp_path / "live" / "results.parquet").equals(
        pq.read_table(tmp_path / "plain" / "results.parquet"))
    for name in ("events.csv", "trajectory.csv", "summary.csv", "photos.csv"):
        assert (tmp_path / "live" / name).read_bytes() == (tmp_path / "plain" / name).read_bytes(), name
    assert plain.metadata["steps_done"] == live.metadata["steps_done"] == 250


def _one_line_error(res, *words):
    assert res.returncode == 1
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cosim-master: error:"), res.stderr
    assert "Traceback" not in res.stderr
    for w in words:
        assert w in lines[0], lines[0]


@pytest.mark.parametrize("url, why", [("bogus", "not a MAVLink address"),
                                      ("udpout:127.0.0.1:99999", "port '99999'"),
                                      ("serial:/dev/ttyS0:57600", "not a MAVLink address")])
def test_unparseable_address_is_refused_before_anything_runs(tmp_path, url, why):
    res = cli("--mavlink", url, "-o", str(tmp_path / "out"))
    _one_line_error(res, "--mavlink", why)
    assert not (tmp_path / "out").exists()             # checked before the output folder is claimed


def test_realtime_must_be_positive(tmp_path):
    _one_line_error(cli("--realtime", "0", "-o", str(tmp_path / "out")), "--realtime", "positive")


def test_port_in_use_is_a_one_line_error(tmp_path):
    holder = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    holder.bind(("127.0.0.1", 0))
    holder.listen(1)
    try:
        port = holder.getsockname()[1]
        res = cli("--mavlink", f"tcpin:127.0.0.1:{port}", "--stop-time", "1", "-o", str(tmp_path / "out"))
    finally:
        holder.close()
    _one_line_error(res, "--mavlink", f"tcpin:127.0.0.1:{port}", "in use")


def test_a_scenario_without_uavs_cannot_stream(tmp_path):
    from tests.ssp_helpers import write_ssp
    ssp = write_ssp(tmp_path / "wind.ssp", {"wind": ROOT / "fmus" / "UavWind.fmu"}, stop=1.0, step=0.1)
    with pytest.raises(CosimError, match="--mavlink.*no UAV monitor"):
        run(ssp, output=None, mavlink=["udpout:127.0.0.1:14550"])


def test_a_campaign_never_streams(tmp_path):
    from master.campaign.spec import load_campaign
    spec = tmp_path / "c.yaml"
    spec.write_text(f"name: c\nscenario: {ROOT / 'ssp' / 'scenarios' / 'paper_area.yaml'}\n"
                    "run:\n  mavlink: udpout:127.0.0.1:14550\n")
    with pytest.raises(CosimError, match="run.mavlink.*unknown run option"):
        load_campaign(spec)


def test_a_ground_station_that_goes_away_is_a_warning_and_the_run_goes_on(tmp_path):
    """The ground station leaves while the run streams: the run must still be going then. Paced at 5x, the
    20 s run streams for at least 4 s of wall time, however busy the machine (pacing only slows a run down);
    the ground station needs its first 2000 bytes and a close within that. Every wait on the run is for an
    event (listening, bytes, the end), each with a deadline far beyond a loaded machine's delays."""
    port = free_port(socket.SOCK_STREAM)
    proc = program_server.Popen([*CLI, "--mavlink", f"tcpin:127.0.0.1:{port}", "--realtime", "5", "--stop-time",
                                 "20", "-o", str(tmp_path / "out")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                client = socket.create_connection(("127.0.0.1", port), timeout=5)
                break
            except OSError:
                assert time.monotonic() < deadline and proc.poll() is None, "the run never listened"
                time.sleep(0.05)
        client.settimeout(120)           # the first bytes come after the FMUs are initialized
        got = b""
        while len(got) < 2000:
            chunk = client.recv(4096)
            assert chunk, f"the run closed the connection after {len(got)} bytes, before the test could leave"
            got += chunk
        client.close()                                   # gone mid-run
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    warning = [ln for ln in err.splitlines() if "warning: --mavlink tcpin" in ln.lower()]
    assert len(warning) == 1 and "disconnected" in warning[0] and warning[0].endswith("the run goes on")
    assert out.startswith("completed: 200 steps")
    assert got[0] == 0xFD                                 # MAVLink 2 frames


def test_mavproxy_sees_every_vehicle_and_its_positions(tmp_path):
    pytest.importorskip("MAVProxy", reason="MAVProxy is not installed (pip install mavproxy: the test extra)")
    mavproxy = shutil.which("mavproxy.py", path=os.path.dirname(sys.executable))
    if mavproxy is None:
        pytest.skip("mavproxy.py is not next to this Python")
    port = free_port()
    tlog = tmp_path / "gcs.tlog"
    gcs = subprocess.Popen([sys.executable, mavproxy, f"--master=udpin:127.0.0.1:{port}", "--non-interactive",
                            "--default-modules=", f"--state-basedir={tmp_path}", f"--logfile={tlog}"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path)
    lines, listening, all_seen = [], threading.Event(), threading.Event()

    def read():                          # MAVProxy's output as it comes: the events the test waits for
        for line in gcs.stdout:
            lines.append(line)
            if "Waiting for heartbeat" in line:
                listening.set()
            if all(any(f"Detected vehicle {k}:1" in ln for ln in lines) for k in (1, 2, 3, 4)):
                all_seen.set()
        listening.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        assert listening.wait(120) and gcs.poll() is None, "".join(lines)
        res = cli("--mavlink", f"udpout:127.0.0.1:{port}", "--realtime", "20", "--stop-time", "6",
                  "-o", str(tmp_path / "out"))
        assert res.returncode == 0, res.stderr
        all_seen.wait(120)               # MAVProxy reads the datagrams at its own pace; the asserts say what is missing
    finally:
        gcs.terminate()
        gcs.wait(timeout=60)
        reader.join(timeout=60)
    out = "".join(lines)
    for k in (1, 2, 3, 4):
        assert f"Detected vehicle {k}:1" in out, out
    from pymavlink import mavutil
    log = mavutil.mavlink_connection(str(tlog))
    positions = {}
    while (msg := log.recv_match(type="GLOBAL_POSITION_INT")) is not None:
        positions.setdefault(msg.get_srcSystem(), []).append(msg)
    assert sorted(positions) == [1, 2, 3, 4]
    base = json.loads((tmp_path / "out" / "run.json").read_text())
    assert base["outcome"] == "completed"
    for msgs in positions.values():
        # the base near Campina Grande (ssp/scenarios/paper_area_zones.yaml: -7.275, -35.965)
        assert all(abs(p.lat * 1e-7 + 7.275) < 0.01 and abs(p.lon * 1e-7 + 35.965) < 0.01 for p in msgs)
