"""A supervised run's shared block lives in /dev/shm under its name only until the child has mapped it; a run killed
with SIGKILL in that moment left it there for good. The name holds the supervisor's process id, and the next
supervised run removes the blocks whose supervisor is gone, and only those.

(The moment is a few microseconds long, too short to hit with a kill from a test: the blocks here are made as such a
run leaves them, with the id of a process that has ended, and of one that still runs.)"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from master.ssp.writer import SspBuilder
from master.supervise import BLOCK_PREFIX, SHARED_FOLDER, run_supervised

pytestmark = pytest.mark.skipif(not os.path.isdir(SHARED_FOLDER), reason="no /dev/shm here")


def _block(pid: int, tag: str) -> Path:
    path = Path(SHARED_FOLDER) / f"{BLOCK_PREFIX}{pid}-{tag}"
    path.write_bytes(b"\0" * 64)
    return path


def test_the_next_run_removes_the_blocks_of_supervisors_that_are_gone(tmp_path, reference_fmus):
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    gone_pid = int(ended.stdout)
    running = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    tag = f"test{os.getpid()}"
    gone, kept = _block(gone_pid, tag), _block(running.pid, tag)
    unnamed = Path(SHARED_FOLDER) / f"{BLOCK_PREFIX}{tag}x"        # as blocks were named before: no owner known
    unnamed.write_bytes(b"")
    try:
        b = SspBuilder("d")
        b.add_component("d", reference_fmus / "fmi2" / "Dahlquist.fmu")
        result = run_supervised(b.write(tmp_path / "d.ssp"), output=tmp_path / "out", stop_time=1.0, step=0.1,
                                record=["d.x"])
        assert result.metadata["outcome"] == "completed"
        assert not gone.exists()
        assert kept.exists() and unnamed.exists()
        # and the run's own block is not left behind
        assert not list(Path(SHARED_FOLDER).glob(f"{BLOCK_PREFIX}{os.getpid()}-*"))
    finally:
        running.kill()
        running.wait()
        for path in (gone, kept, unnamed):
            path.unlink(missing_ok=True)
