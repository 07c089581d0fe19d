"""SITL process management (sitlsim/process.py) with a fake 'SITL': a script that ignores SIGTERM, starts a
child of its own and sleeps, as JSON-mode SITL does while it waits for physics.

Expectations: POSIX semantics (a process killed by SIGKILL is gone; PR_SET_PDEATHSIG delivers SIGKILL to the
child when its parent dies; an flock is released when its owner dies) and the port layout of ArduPilot's
``-I N`` (5760 + 10 N, ...)."""
from __future__ import annotations

import fcntl
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import pytest
from sitlveh_helpers import REPO

from sitlsim.process import SitlError, SitlProcess, claim_instance, find_binary, ports

FAKE_SITL = textwrap.dedent("""\
    #!{python}
    import os, signal, subprocess, sys, time
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    child = subprocess.Popen([sys.executable, "-c", "import signal, time; signal.signal(signal.SIGTERM, "
                              "signal.SIG_IGN); time.sleep(600)"])
    with open("pids", "w") as f:
        f.write(f"{{os.getpid()}} {{child.pid}}\\n")
    time.sleep(600)
""")


@pytest.fixture
def locks(tmp_path, monkeypatch):
    d = tmp_path / "locks"
    monkeypatch.setenv("COSIM_SITL_LOCKS", str(d))
    return d


@pytest.fixture
def fake_sitl(tmp_path):
    p = tmp_path / "fake_sitl"
    p.write_text(FAKE_SITL.format(python=sys.executable))
    p.chmod(0o755)
    return str(p)


def _gone(pid: int, within: float = 5.0) -> bool:
    end = time.monotonic() + within
    while time.monotonic() < end:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        try:   # a zombie child of ours counts as gone once reaped
            if os.waitpid(pid, os.WNOHANG)[0] == pid:
                return True
        except ChildProcessError:
            pass
        if _zombie(pid):
            return True
        time.sleep(0.05)
    return False


def _zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def _pids(workdir, within: float = 10.0) -> tuple[int, int]:
    f = workdir / "pids"
    end = time.monotonic() + within
    while time.monotonic() < end:
        if f.is_file() and f.read_text().endswith("\n"):
            a, b = f.read_text().split()
            return int(a), int(b)
        time.sleep(0.05)
    raise AssertionError("the fake SITL did not start")


def test_stop_kills_a_sitl_that_ignores_sigterm_and_its_children(tmp_path, locks, fake_sitl):
    p = SitlProcess(fake_sitl, tmp_path / "w", model="JSON:127.0.0.1", home=(0, 0, 0, 0))
    p.start()
    sitl, child = _pids(tmp_path / "w")
    os.kill(sitl, signal.SIGTERM)            # ignored, as JSON-mode SITL does
    time.sleep(0.2)
    assert p.alive()
    p.stop()
    assert _gone(sitl) and _gone(child)
    assert not p.alive()
    # the instance is free again
    again = claim_instance(p.wanted if p.wanted is not None else None)
    again.release()


def test_a_killed_master_leaves_no_sitl_behind(tmp_path, locks, fake_sitl):
    master = textwrap.dedent(f"""\
        import sys, time
        sys.path.insert(0, {str(REPO / 'fmu_sources')!r})
        from sitlsim.process import SitlProcess
        p = SitlProcess({fake_sitl!r}, {str(tmp_path / 'w')!r}, model="quad", home=(0, 0, 0, 0))
        p.start()
        print(p.number, flush=True)
        time.sleep(600)
    """)
    m = subprocess.Popen([sys.executable, "-c", master], stdout=subprocess.PIPE, text=True,
                         env={**os.environ, "COSIM_SITL_LOCKS": str(locks)})
    number = int(m.stdout.readline())
    sitl, child = _pids(tmp_path / "w")
    m.kill()                                  # SIGKILL: no atexit, no finally
    m.wait()
    try:
        assert _gone(sitl), "SITL survived its master (PR_SET_PDEATHSIG)"
    finally:
        # PR_SET_PDEATHSIG covers the SITL process itself, not processes it would start (arducopter starts none)
        os.killpg(sitl, signal.SIGKILL) if not _gone(child, 0.5) else None
    # the dead master's lock is gone with it (its ports may meanwhile be taken by another SITL on the machine)
    fd = os.open(locks / f"instance-{number}.lock", os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    finally:
        os.close(fd)


def test_instances_do_not_collide_and_busy_ports_are_skipped(locks):
    a = claim_instance()
    b = claim_instance()
    try:
        assert a.number != b.number
        with pytest.raises(SitlError, match="in use"):
            claim_instance(a.number)
        # a listener on the next instance's MAVLink port (a SITL started by hand) makes it skip that one
        # (another SITL on the machine may hold the next one already: block the first free port above)
        n = max(a.number, b.number) + 1
        while True:
            blocker = socket.socket()
            blocker.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                blocker.bind(("127.0.0.1", ports(n)["mavlink"]))
                break
            except OSError:
                blocker.close()
                n += 1
        blocker.listen(1)
        try:
            c = claim_instance(first=n)
            assert c.number > n
            c.release()
        finally:
            blocker.close()
    finally:
        a.release()
        b.release()


def test_port_layout_of_instance_n():
    assert ports(3) == {"mavlink": 5790, "serial1": 5792, "serial2": 5793, "physics": 9032, "rc": 5531}


def test_missing_and_not_executable_binaries_say_how_to_fix_it(tmp_path, monkeypatch):
    monkeypatch.delenv("ARDUPILOT_SITL", raising=False)
    with pytest.raises(SitlError, match="ARDUPILOT_SITL"):
        find_binary("")
    with pytest.raises(SitlError, match="not found: .*nope"):
        find_binary(str(tmp_path / "nope"))
    f = tmp_path / "arducopter"
    f.write_text("x")
    f.chmod(0o644)
    with pytest.raises(SitlError, match="not executable"):
        find_binary(str(f))
    monkeypatch.setenv("ARDUPILOT_SITL", str(f))
    with pytest.raises(SitlError, match="not executable"):
        find_binary("")


def test_a_crashing_sitl_is_reported_with_its_exit_code(tmp_path, locks):
    crash = tmp_path / "crash"
    crash.write_text("#!/bin/sh\necho 'boom' >&2\nexit 3\n")
    crash.chmod(0o755)
    p = SitlProcess(str(crash), tmp_path / "w", model="quad", home=(0, 0, 0, 0))
    p.start()
    p.proc.wait(5)
    assert "exited with code 3" in p.exit_reason()
    assert "boom" in (tmp_path / "w" / "sitl.log").read_text()
    p.stop()
