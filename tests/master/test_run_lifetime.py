"""A supervised run's whole life, with the signals sent where they come from in practice: ``kill -9`` of the
``cosim-master run`` parent leaves no process behind and a readable, consistent folder; a ``--timeout`` and
SIGTERM (to the supervisor alone, and to its process group as ``timeout``/systemd send it) end a run whose
rows stream fast, with a readable Parquet file and run.json. Real processes of the CLI (forked by
tests/program_server.py, as a new interpreter would start them); every wait is on a condition with a generous
deadline, no duration is asserted."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

import master
import program_server
from cli_in_process import run_cli

CLI = [sys.executable, "-m", "master.cli"]
REPO = Path(master.__file__).parents[1]
OSCILLATOR = REPO / "ssp" / "coupling" / "oscillator_fd.ssp"
DEADLINE_S = 90.0


def _env():
    return dict(os.environ, PYTHONPATH=str(REPO))


def _stat(pid: int):
    """(state, ppid) of a process, None when it is gone (a zombie counts as gone: nothing of it runs)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    state, ppid = text.rsplit(")", 1)[1].split()[:2]
    return None if state in ("Z", "X") else (state, int(ppid))


def _descendants(pid: int) -> set[int]:
    """Every living process below ``pid``, from the ppid field of /proc/<pid>/stat."""
    children: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            st = _stat(int(d.name))
            if st is not None:
                children.setdefault(st[1], []).append(int(d.name))
    out, todo = set(), [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            if c not in out:
                out.add(c)
                todo.append(c)
    return out


def _wait_for(cond, what: str, p=None):
    deadline = time.monotonic() + DEADLINE_S
    while not cond():
        if time.monotonic() > deadline:
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            pytest.fail(f"not within {DEADLINE_S:g} s: {what}")
        time.sleep(0.05)


def _start(out: Path, *extra) -> subprocess.Popen:
    return program_server.Popen(CLI + ["run", str(OSCILLATOR), "-o", str(out), *extra], env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)


def _rows_streaming(out: Path, p: subprocess.Popen):
    """Waits until rows are being written (a first block is in the CSV)."""
    csv = out / "results.csv"
    _wait_for(lambda: (csv.is_file() and csv.stat().st_size > 1 << 20) or p.poll() is not None,
              "the first rows written", p)
    assert p.poll() is None, p.communicate()


def _readable_and_consistent(out: Path) -> dict:
    meta = json.loads((out / "run.json").read_text())
    rows = pq.ParquetFile(out / "results.parquet").metadata.num_rows
    assert rows == meta["rows_recorded"] > 0, (rows, meta)
    if (out / "results.csv").exists():
        assert len(pd.read_csv(out / "results.csv", usecols=["time"])) == rows
    assert not (out / ".cosim-master.reserve").exists() and not (out / ".cosim-master.stack").exists()
    assert not list(out.glob("*.tmp"))
    return meta


# -- kill -9 of the parent --------------------------------------------------------------------------------
def test_kill_9_of_the_parent_leaves_no_process_and_a_readable_folder(tmp_path):
    out = tmp_path / "out"
    p = _start(out, "--step", "1e-4", "--stop-time", "1e6")
    try:
        _rows_streaming(out, p)
        below = _descendants(p.pid)
        assert below, "the supervised run has a simulation process"
        p.kill()
        p.wait(timeout=60)
        _wait_for(lambda: not any(_stat(c) for c in below), f"the simulation processes {below} end")
    finally:
        for c in _descendants(p.pid):       # a failing test leaves nothing running either
            os.kill(c, signal.SIGKILL)
    # the simulation process wrote what it could: the CSV to its last whole line (and its own unsent rows), the
    # Parquet file rebuilt from it, and run.json saying what happened
    meta = _readable_and_consistent(out)
    assert meta["outcome"] == "interrupted" and "supervising cosim-master process died" in meta["error"]
    assert meta["supervised"] == {"parent_died": True}


# -- stop requests while rows stream fast ---------------------------------------------------------------
FAST = ["--step", "1e-5", "--stop-time", "1000"]     # every-step recording: the pipe is never empty


def test_a_timeout_is_honoured_while_rows_stream(tmp_path):
    # both processes are busy for the whole timeout (the child computing rows, the supervisor taking them), and the
    # files grow with it: 2 s (millions of rows) where the first block is written within milliseconds of the start
    out = tmp_path / "out"
    p = _start(out, *FAST, "--timeout", "2")
    _wait_for(lambda: p.poll() is not None, "the run ends after its 2 s timeout", p)
    _, err = p.communicate()
    assert p.returncode == 1 and "timed out after 2 s" in err and "Traceback" not in err, err
    meta = _readable_and_consistent(out)
    assert "timed out after 2 s" in meta["error"]


@pytest.mark.parametrize("to", ["supervisor", "group", "group", "group"])
def test_sigterm_ends_a_fast_streaming_run_with_its_files_whole(tmp_path, to):
    out = tmp_path / "out"
    p = _start(out, *FAST)
    _rows_streaming(out, p)
    if to == "supervisor":
        p.send_signal(signal.SIGTERM)
    else:
        os.killpg(p.pid, signal.SIGTERM)        # as `timeout`, systemd or `kill -- -PGID` send it
    _wait_for(lambda: p.poll() is not None, f"SIGTERM to the {to} ends the run", p)
    _, err = p.communicate()
    assert p.returncode == 143, err
    lines = [ln for ln in err.splitlines() if ln.startswith("cosim-master:") and "WARNING" not in ln]
    assert len(lines) == 1 and "stopped by SIGTERM" in lines[0] and "Traceback" not in err, err
    assert "component" not in lines[0], lines[0]        # an interrupt is nobody's fault
    meta = _readable_and_consistent(out)
    assert meta["outcome"] == "interrupted"


# -- interrupts after the simulation has ended: the products are written, the status says so -------------------
UAV = REPO / "ssp" / "paper_zones_1uav_A.ssp"
# the run's products take seconds to write on a loaded machine (maps, summaries): a first monitor that takes
# a known while to finish makes that window wide, and tells the test (a marker file) when it has begun
SLOW_FINISH = """
import sys, time
from pathlib import Path
import master.execution as execution
from master.observers import Observer
MARKER = Path(sys.argv[1])

class SlowFinish(Observer):
    name = "slow_finish"
    def finish(self, out_dir, outcome):
        MARKER.touch()
        time.sleep(8.0)
        return {}

monitors_for = execution.monitors_for
execution.monitors_for = lambda *a, **k: [SlowFinish(), *monitors_for(*a, **k)]
sys.argv = ["cosim-master"] + sys.argv[2:]
from master.cli import entry
sys.exit(entry())
"""
PRODUCTS = ("summary.json", "map.png", "summary.csv", "photos.csv", "trajectory.csv", "results.parquet")


def _uav_run(tmp_path, *extra):
    out, marker = tmp_path / "out", tmp_path / "finishing"
    p = program_server.Popen([sys.executable, "-c", SLOW_FINISH, str(marker), "run", str(UAV), "-o", str(out), *extra],
                         env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    _wait_for(lambda: marker.exists() or p.poll() is not None, "the run's finishing phase", p)
    assert p.poll() is None, p.communicate()
    return p, out


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm-to-supervisor", "sigterm-to-group", "ctrl-c-no-supervise"])
def test_an_interrupt_after_the_end_keeps_every_product_and_says_completed(tmp_path, how):
    p, out = _uav_run(tmp_path, *(["--no-supervise"] if how.endswith("no-supervise") else []))
    if how == "sigterm-to-supervisor":
        p.send_signal(signal.SIGTERM)
    else:
        os.killpg(p.pid, signal.SIGTERM if how == "sigterm-to-group" else signal.SIGINT)
    _wait_for(lambda: p.poll() is not None, "the run ends", p)
    stdout, err = p.communicate()
    meta = json.loads((out / "run.json").read_text())
    # the simulation reached its end and every product was written: a completed run, whatever the interrupt
    assert [f for f in PRODUCTS if not (out / f).is_file()] == []
    assert meta["outcome"] == "completed", meta.get("error")
    assert p.returncode == 0 and stdout.startswith("completed"), (p.returncode, stdout, err)
    if "supervised" in meta:
        assert meta["supervised"]["child_exit"] == 0


def test_a_second_ctrl_c_while_the_products_are_written_still_ends_the_run(tmp_path):
    p, out = _uav_run(tmp_path)
    os.killpg(p.pid, signal.SIGINT)
    time.sleep(1.0)     # not a timing assumption: the second Ctrl-C only has to come after the first
    os.killpg(p.pid, signal.SIGINT)
    _wait_for(lambda: p.poll() is not None, "the run ends", p)
    _, err = p.communicate()
    assert p.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.startswith("cosim-master:") and "WARNING" not in ln]
    assert len(lines) == 1 and "Traceback" not in err, err
    # the simulation had ended: no component was running, none is blamed
    assert "interrupted by the user" in lines[0] and "component" not in lines[0], lines[0]
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "interrupted" and "failed_component" not in meta
    assert pq.ParquetFile(out / "results.parquet").metadata.num_rows == meta["rows_recorded"] > 0


# -- the output folder: a rerun keeps the earlier run until it has results; one line for a folder it cannot use ----
def _short(out, *extra):
    """A short run, through the command in this process: what it does with its output folder is the subject."""
    return run_cli(["run", str(OSCILLATOR), "--stop-time", "1", "-o", str(out), *extra])


def _one_line(r) -> str:
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("cosim-master:") and "WARNING" not in ln]
    assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    return lines[0]


@pytest.mark.parametrize("supervised", [True, False])
def test_a_rerun_without_results_gives_the_earlier_run_back(tmp_path, supervised):
    out = tmp_path / "out"
    extra = [] if supervised else ["--no-supervise"]
    assert _short(out, *extra).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    # fails before its first row (an FMU that cannot be instantiated with this value)
    r = _short(out, "--param", "A.nosuch=1", *extra)
    assert r.returncode == 1
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    # a rerun that has results replaces the earlier run as a whole
    assert _short(out, "--stop-time", "2", "--no-csv", *extra).returncode == 0
    meta = json.loads((out / "run.json").read_text())
    assert meta["rows_recorded"] == 201 and not (out / "results.csv").exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".cosim-master.previous")]


def test_a_rerun_killed_before_its_results_gives_the_earlier_run_back_to_the_next_run(tmp_path):
    from master.results import claim_output_folder, release_output_folder
    out = tmp_path / "out"
    assert _short(out).returncode == 0
    before = (out / "results.parquet").read_bytes()
    claim_output_folder(out)            # a rerun claimed the folder, then died (kill -9) before any row
    release_output_folder(out)
    assert not (out / "results.parquet").exists()
    r = _short(out, "--param", "A.nosuch=1")       # the next run fails too: the earlier run is there again
    assert r.returncode == 1 and (out / "results.parquet").read_bytes() == before


def test_a_concurrent_run_into_the_same_folder_is_told_so(tmp_path):
    out = tmp_path / "out"
    p = _start(out, "--step", "1e-3", "--stop-time", "1e6")
    try:
        _wait_for(lambda: (out / "results.parquet").exists() or p.poll() is not None, "the first run started", p)
        for extra in ([], ["--no-supervise"]):
            line = _one_line(_short(out, *extra))
            assert "another cosim-master run is writing into this output folder" in line, line
    finally:
        os.killpg(p.pid, signal.SIGTERM)
        p.communicate(timeout=120)


@pytest.fixture
def read_only_folder(tmp_path):
    mnt = tmp_path / "ro"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode != 0:       # root sees no permission bits: only a read-only mount makes a folder read-only
        pytest.skip("cannot mount a tmpfs here (needs root): " + r.stderr.decode().strip())
    try:
        assert _short(mnt / "earlier").returncode == 0
        (mnt / "empty").mkdir()
        subprocess.run(["mount", "-o", "remount,ro", str(mnt)], check=True, capture_output=True)
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_a_read_only_output_folder_is_one_line(read_only_folder):
    campaign = REPO / "ssp" / "campaigns" / "smoke.yaml"
    for name in ("earlier", "empty", "new/sub"):
        out = read_only_folder / name
        for extra in ([], ["--no-supervise"]):
            line = _one_line(_short(out, *extra))
            assert str(out) in line and "Read-only file system" in line, line
        line = _one_line(run_cli(["campaign", str(campaign), "-o", str(out), "--no-progress"]))
        assert str(out) in line and "Read-only file system" in line, line



# -- a campaign stopped by SIGTERM says so -------------------------------------------------------------------
@pytest.mark.parametrize("to", ["parent", "group"])
def test_sigterm_stops_a_campaign_with_its_summary(tmp_path, to):
    out = tmp_path / "camp"
    p = program_server.Popen(CLI + ["campaign", str(REPO / "ssp" / "campaigns" / "smoke.yaml"), "-o", str(out),
                                "--no-progress", "--workers", "2"], env=_env(), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    _wait_for(lambda: (out / "campaign.json").exists() or p.poll() is not None, "the campaign started", p)
    below = _descendants(p.pid)
    if to == "parent":
        p.send_signal(signal.SIGTERM)
    else:
        os.killpg(p.pid, signal.SIGTERM)
    _wait_for(lambda: p.poll() is not None, "the campaign ends", p)
    stdout, err = p.communicate()
    if p.returncode == 0:
        pytest.skip("the campaign finished before the signal came")
    assert p.returncode == 143 and "Traceback" not in err, (p.returncode, stdout, err)
    # the summary when the runs had begun; before them (still planning) the one line of an interrupted command
    assert "Interrupted" in stdout or err.strip() == ("cosim-master: stopped by SIGTERM; the same command resumes "
                                                      "the campaign"), (stdout, err)
    _wait_for(lambda: not any(_stat(c) for c in below), "the workers end")
