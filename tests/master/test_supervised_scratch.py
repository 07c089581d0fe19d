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


def test_unsupervised_run_killed_leaves_its_ssp_for_the_next_run_to_sweep(tmp_path, test_fmus):
    """A ``--no-supervise`` run killed with SIGKILL (its FMU hangs in doStep) cannot remove its unpacked SSP; it is
    in a folder named for the run's process, which the next run removes once that process is gone. Before, the
    killed run's `cosim-ssp-*` folder stayed in the temporary folder for good."""
    import signal
    import time
    b = SspBuilder("hang", stop=1.0, step=0.1)
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": 5, "fail_time": 0.5})
    hang = b.write(tmp_path / "hang.ssp")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]), TMPDIR=str(tmp))
    proc = subprocess.Popen(CLI + ["run", str(hang), "-o", str(tmp_path / "hung"), "--no-progress", "--no-supervise"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        # the FMU's log file is made after the SSP is unpacked, and the FMU hangs from t=0.5 on: killed from here
        # on, the run cannot finish on its own
        while not (tmp_path / "hung" / "fmu.log").is_file():
            assert proc.poll() is None and time.monotonic() < deadline, "the run ended before it hung"
            time.sleep(0.02)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    left = [p.name for p in tmp.rglob("cosim-ssp-*")]
    assert len(left) == 1, left                     # what the killed run could not remove ...
    b = SspBuilder("fine", stop=1.0, step=0.1)
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": 0})
    r = _run(b.write(tmp_path / "fine.ssp"), tmp_path / "out", tmp, "--no-supervise")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp.iterdir()) == []      # ... the next run removed, with its own
