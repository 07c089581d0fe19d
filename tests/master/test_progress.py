"""``run`` shows a progress bar by default when a person watches (stderr a terminal) and nothing that would flood
a log when stderr is a pipe or a file; ``--progress``/``--no-progress`` decide either way."""
import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

import master
import program_server
from cli_in_process import run_cli


def _run(args, cwd, stderr_tty: bool) -> tuple[int, str]:
    """The CLI run with its stderr a pseudo-terminal (in a process of its own, tests/program_server.py; of 24 x 100 characters: a fresh pty has no
    size, and a bar fits in none) or not a terminal (in this process, its stderr a file: what the command asks,
    isatty(), is false for a pipe and a log file alike); returns the exit code and what reached stderr."""
    if not stderr_tty:
        r = run_cli(args, cwd)
        return r.returncode, r.stderr
    cmd = [sys.executable, "-m", "master.cli", *map(str, args)]
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))
    env.pop("COLUMNS", None)
    parent, child = pty.openpty()
    fcntl.ioctl(child, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    p = program_server.Popen(cmd, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=child)
    os.close(child)
    out = b""
    while True:
        try:
            data = os.read(parent, 4096)
        except OSError:         # EIO: every holder of the terminal's other end has closed it
            break
        if not data:
            break
        out += data
    os.close(parent)
    return p.wait(timeout=120), out.decode(errors="replace")


@pytest.fixture
def fmu(tmp_path, test_fmus):
    path = tmp_path / "Integrator.fmu"
    path.write_bytes(Path(test_fmus["c2:Integrator"]).read_bytes())
    return path


RUN = ["run", "Integrator.fmu", "--stop-time", "20", "--step", "1e-3", "-o"]


@pytest.mark.parametrize("supervise", [[], ["--no-supervise"]])
def test_a_bar_on_a_terminal_by_default(tmp_path, fmu, supervise):
    code, err = _run(RUN + ["out", *supervise], tmp_path, stderr_tty=True)
    assert code == 0, err
    assert "0/20000" in err and "step/s" in err


def test_no_bar_in_a_pipe_by_default(tmp_path, fmu):
    code, err = _run(RUN + ["out"], tmp_path, stderr_tty=False)
    assert code == 0, err
    assert err == ""


def test_asked_for_either_way(tmp_path, fmu):
    code, err = _run(RUN + ["out1", "--progress"], tmp_path, stderr_tty=False)
    assert code == 0 and "step/s" in err
    code, err = _run(RUN + ["out2", "--no-progress"], tmp_path, stderr_tty=True)
    assert code == 0 and "step/s" not in err and "%|" not in err


def test_campaign_and_study_decide_alike(monkeypatch):
    """campaign and study had a bar in a pipe too (--no-progress aside): the same test as run's now."""
    import io

    from master.cli import _progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert _progress(None) is False and _progress(True) is True
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert _progress(None) is True and _progress(False) is False


@pytest.fixture
def campaign_dir(tmp_path, test_fmus):
    """A finished campaign of two runs (an SSP of one integrator) to report on."""
    from master.campaign.runner import run_campaign
    from master.ssp.writer import SspBuilder
    b = SspBuilder("one", stop=1.0, step=0.1)
    b.add_component("I", test_fmus["c2:Integrator"], params={"a": -1.0, "x0": 1.0})
    b.write(tmp_path / "one.ssp")
    (tmp_path / "c.yaml").write_text("name: c\nscenario: one.ssp\ngrid:\n  param:I.x0: [1.0, 2.0]\n")
    assert run_campaign(tmp_path / "c.yaml", output=tmp_path / "c", workers=1, progress=False).ok
    return tmp_path / "c"


def test_report_shows_a_bar_on_a_terminal_only(tmp_path, campaign_dir):
    """issue 25: `report` was silent for ~24 s on the paper campaign; a bar of its steps now, none in a pipe."""
    code, err = _run(["report", campaign_dir], tmp_path, stderr_tty=True)
    assert code == 0, err
    assert "report c: 3/3 steps" in err and "writing report.md" in err, err
    code, err = _run(["report", campaign_dir], tmp_path, stderr_tty=False)
    assert code == 0 and err == "", err
    code, err = _run(["report", campaign_dir, "--progress"], tmp_path, stderr_tty=False)
    assert code == 0 and "3/3 steps" in err, err
    code, err = _run(["report", campaign_dir, "--no-progress"], tmp_path, stderr_tty=True)
    assert code == 0 and "steps" not in err, err
    assert (campaign_dir / "report" / "report.md").read_text().startswith("# Campaign report: c")
