"""A supervised run leaves nothing in the temporary folder, also when its simulation process dies: the child's
temporary files (the unpacked SSP above all) live in a folder its supervisor removes once the child is gone. A
child killed by an FMU's abort() cannot remove them itself; before this, every such run left its unpacked SSP
behind (thousands of `cosim-ssp-*` folders on a machine that runs the fault tests)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

import master
import program_server
from master.ssp.writer import SspBuilder

CLI = [sys.executable, "-m", "master.cli"]


def _run(ssp: Path, out: Path, tmp: Path, *flags) -> subprocess.CompletedProcess:
    """The command as its own process (forked by tests/program_server.py: its TMPDIR read when first used)."""
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]), TMPDIR=str(tmp))
    return program_server.run(CLI + ["run", str(ssp), "-o", str(out), "--no-progress", *flags],
                              capture_output=True, text=True, env=env, timeout=180)


@pytest.mark.parametrize("mode,ends", [(0, 0), (3, 1)], ids=["completed", "abort in doStep"])
def test_no_temporary_files_are_left(tmp_path, test_fmus, mode, ends):
    b = SspBuilder("faulty", stop=1.0, step=0.1)
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": mode, "fail_time": 0.5})
    ssp = b.write(tmp_path / "faulty.ssp")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    r = _run(ssp, tmp_path / "out", tmp)
    assert r.returncode == ends and "Traceback" not in r.stderr, r.stderr
    if mode:
        assert "SIGABRT" in r.stderr, r.stderr          # the child did die: it could not clean up after itself
    assert (tmp_path / "out" / "run.json").is_file()
    assert sorted(p.name for p in tmp.iterdir()) == []


def test_scratch_of_a_killed_supervisor_is_swept_by_the_next_run(tmp_path):
    """A supervisor killed with SIGKILL cannot remove its child's scratch folder; the next supervised run removes
    the folders named for a process that is gone, and no other: a live supervisor's, and anything in the shared
    temporary folder not named for a process, stay."""
    from master.supervise import SCRATCH_PREFIX, _sweep_left_scratch
    gone = subprocess.Popen(["true"])
    gone.wait()                                 # reaped: its pid names no process (until the kernel reuses it)
    made = {}
    for key, pid in (("gone", gone.pid), ("alive", os.getppid()), ("unnamed", "x")):
        d = tmp_path / f"{SCRATCH_PREFIX}{pid}-tag"
        (d / "cosim-ssp-1" / "resources").mkdir(parents=True)
        (d / "cosim-ssp-1" / "SystemStructure.ssd").write_text("<ssd/>")
        made[key] = d
    other = tmp_path / "cosim-master-results"
    other.mkdir()
    assert _sweep_left_scratch(str(tmp_path)) == [made["gone"].name]
    assert not made["gone"].exists()
    assert made["alive"].is_dir() and made["unnamed"].is_dir() and other.is_dir()
