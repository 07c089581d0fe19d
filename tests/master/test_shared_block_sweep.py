"""A supervised run's shared block lives in /dev/shm under its name only from the child's making it until the
supervisor has mapped it; a run killed with SIGKILL in that moment left it there for good. The name holds the
supervisor's process id, and the next supervised run removes the blocks whose supervisor is gone, and only those.
The moment is held open here: the supervisor stops itself when the child's word of its block comes."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_in_process import run_cli

from master.ssp.writer import SspBuilder
import master
import program_server
from master.supervise import BLOCK_PREFIX, SHARED_FOLDER, UNNAMED_BLOCK_AGE_S, run_supervised

pytestmark = pytest.mark.skipif(not os.path.isdir(SHARED_FOLDER), reason="no /dev/shm here")


def _block(pid: int, tag: str) -> Path:
    path = Path(SHARED_FOLDER) / f"{BLOCK_PREFIX}{pid}-{tag}"
    path.write_bytes(b"\0" * 64)
    return path


def _wait_for(what, condition, timeout=60.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.002)


def _dahlquist(tmp_path, reference_fmus):
    b = SspBuilder("d")
    b.add_component("d", reference_fmus / "fmi2" / "Dahlquist.fmu")
    return b.write(tmp_path / "d.ssp")


# the supervisor stops itself (SIGSTOP) when the child's word of its block comes, before it maps it: the moment
# a SIGKILL leaves the block behind, held open for the test
STOPPED_AT_THE_BLOCK = """
import os, signal, sys
import master.supervise as supervise
handle = supervise._Supervisor.handle

def stop_at_the_block(self, msg, conn):
    if msg[0] == "schema":
        os.kill(os.getpid(), signal.SIGSTOP)
    return handle(self, msg, conn)
supervise._Supervisor.handle = stop_at_the_block
from master.cli import entry
sys.argv[0] = "cosim-master"
sys.exit(entry())
"""


def test_a_block_left_by_a_run_killed_with_sigkill_goes_at_the_next_run(tmp_path, reference_fmus):
    ssp = _dahlquist(tmp_path, reference_fmus)
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))
    p = program_server.Popen([sys.executable, "-c", STOPPED_AT_THE_BLOCK, "run", str(ssp), "-o", str(tmp_path / "killed"),
                          "--stop-time", "1e6", "--step", "0.1"], env=env, start_new_session=True,
                         stderr=subprocess.DEVNULL)
    left = lambda: list(Path(SHARED_FOLDER).glob(f"{BLOCK_PREFIX}{p.pid}-*"))    # noqa: E731
    try:
        _wait_for("the supervisor to stop at the child's block",
                  lambda: p.poll() is not None or _state(p.pid) == "T")
        assert p.poll() is None
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    blocks = left()
    assert len(blocks) == 1             # left behind: nobody removes it
    try:
        result = run_supervised(ssp, output=tmp_path / "next", stop_time=1.0, step=0.1, record=["d.x"])
        assert result.metadata["outcome"] == "completed"
        assert not blocks[0].exists()
    finally:
        blocks[0].unlink(missing_ok=True)


def _state(pid: int) -> str:
    """The process's state letter in /proc (T: stopped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return ""


def test_the_next_run_removes_the_blocks_of_supervisors_that_are_gone(tmp_path, reference_fmus):
    ended = subprocess.Popen(["true"])
    ended.wait()                    # reaped: its pid names no process (until the kernel reuses it)
    gone_pid = ended.pid
    running = subprocess.Popen(["sleep", "60"])
    tag = f"test{os.getpid()}"
    gone, kept = _block(gone_pid, tag), _block(running.pid, tag)
    # as blocks were named before: no owner known; one as old as those left on a machine goes, a recent one stays
    unnamed, old = Path(SHARED_FOLDER) / f"{BLOCK_PREFIX}{tag}x", Path(SHARED_FOLDER) / f"{BLOCK_PREFIX}{tag}y"
    unnamed.write_bytes(b"")
    old.write_bytes(b"")
    an_hour_ago = time.time() - UNNAMED_BLOCK_AGE_S - 60
    os.utime(old, (an_hour_ago, an_hour_ago))
    try:
        result = run_supervised(_dahlquist(tmp_path, reference_fmus), output=tmp_path / "out", stop_time=1.0,
                                step=0.1, record=["d.x"])
        assert result.metadata["outcome"] == "completed"
        assert not gone.exists() and not old.exists()
        assert kept.exists() and unnamed.exists()
        # and the run's own block is not left behind
        assert not list(Path(SHARED_FOLDER).glob(f"{BLOCK_PREFIX}{os.getpid()}-*"))
    finally:
        running.kill()
        running.wait()
        for path in (gone, kept, unnamed, old):
            path.unlink(missing_ok=True)


@pytest.mark.parametrize("supervised", [True, False], ids=["supervised", "no-supervise"])
def test_an_fmu_that_cannot_start_leaves_no_results_files(tmp_path, reference_fmus, supervised):
    """The child now makes its shared block itself and goes on: the supervisor still opens its result files only
    once the child has started its FMUs, so a child that never began recording leaves none, as an unsupervised run
    does (its binary here is not a shared library)."""
    import zipfile
    good = reference_fmus / "fmi2" / "Dahlquist.fmu"
    bad = tmp_path / "Dahlquist.fmu"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(bad, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            dst.writestr(item, b"not a shared library" if item.filename.endswith(".so") else data)
    b = SspBuilder("d")
    b.add_component("d", bad)
    ssp = b.write(tmp_path / "d.ssp")
    out = tmp_path / "out"
    r = run_cli(["run", str(ssp), "-o", str(out), "--stop-time", "1", "--step", "0.1"]
                + ([] if supervised else ["--no-supervise"]))
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert (out / "run.json").is_file()
    assert not (out / "results.csv").exists() and not (out / "results.parquet").exists()
