"""One ArduPilot SITL process: start it in its own folder, find it free ports, and never leave it behind.

Ports: SITL's ``-I N`` shifts every port by 10 N (MAVLink TCP 5760+10N, SERIAL1/2 5762/5763+10N, JSON physics
UDP 9002+10N, RC input UDP 5501+10N).  Several runs and campaign workers on one machine must not pick the same
N, so :func:`claim_instance` takes N only when (1) an exclusive ``flock`` on ``<lock dir>/instance-N.lock``
succeeds (the kernel drops it when the owner dies, so a killed master frees its instance without clean-up) and
(2) every port of N can be bound on all interfaces (SITL listens on all of them), which also skips a SITL that
somebody started by hand.

Clean-up: SITL runs in its own process group (so a Ctrl-C on the terminal reaches the master only, which
then stops it) and asks the kernel for SIGKILL when its parent dies (``PR_SET_PDEATHSIG``, Linux): a master
killed with SIGKILL takes its SITLs with it.  :meth:`SitlProcess.stop` sends SIGKILL to the group, because
in JSON mode SITL ignores SIGTERM while it waits for physics.  PR_SET_PDEATHSIG fires when the *thread* that
started the child exits, so start SITL from a thread that lives as long as the run (the master's main thread).
"""
from __future__ import annotations

import atexit
import ctypes
import errno
import fcntl
import os
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

__all__ = ["SitlProcess", "SitlError", "claim_instance", "Instance", "ports", "find_binary", "MAX_INSTANCE"]

MAVLINK_BASE, PHYSICS_BASE, RC_BASE = 5760, 9002, 5501
MAX_INSTANCE = 200          # 5760 + 10*200 stays clear of the physics ports 9002+
ENV_BINARY = "ARDUPILOT_SITL"
PR_SET_PDEATHSIG = 1
#: SITL's simulated GPS and real-time clock start at this UTC time (2025-01-01 00:00:00) instead of the wall
#: clock's, so the firmware's GPS time stamps and its logs are the same in every run
START_TIME_UTC = 1735689600


_LIVE: set = set()        # started and not yet stopped: stopped at interpreter exit, whatever else happened


@atexit.register
def _stop_all():
    for p in list(_LIVE):
        p.stop()


class SitlError(RuntimeError):
    """SITL could not be started, or it died or went silent (one-line reason)."""


def ports(instance: int) -> dict:
    """The ports SITL instance N uses on 127.0.0.1."""
    o = 10 * int(instance)
    return {"mavlink": MAVLINK_BASE + o, "serial1": MAVLINK_BASE + 2 + o, "serial2": MAVLINK_BASE + 3 + o,
            "physics": PHYSICS_BASE + o, "rc": RC_BASE + o}


def _lock_dir() -> Path:
    d = Path(os.environ.get("COSIM_SITL_LOCKS") or Path(tempfile.gettempdir()) / f"cosim-sitl-{os.getuid()}")
    d.mkdir(parents=True, exist_ok=True)
    return d


def _port_free(port: int, kind: int) -> bool:
    s = socket.socket(socket.AF_INET, kind)
    try:
        if kind == socket.SOCK_STREAM:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)   # as SITL itself binds: TIME_WAIT is fine
        s.bind(("", port))
        return True
    except OSError:
        return False
    finally:
        s.close()


def instance_ports_free(n: int) -> bool:
    p = ports(n)
    return (all(_port_free(p[k], socket.SOCK_STREAM) for k in ("mavlink", "serial1", "serial2"))
            and all(_port_free(p[k], socket.SOCK_DGRAM) for k in ("physics", "rc")))


class Instance:
    """A claimed instance number; ``release()`` (or the owner's death) frees it."""

    def __init__(self, number: int, fd: int | None):
        self.number = number
        self._fd = fd

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)       # closing drops the flock
            self._fd = None


def claim_instance(wanted: int | None = None, first: int = 0) -> Instance:
    """Claim instance ``wanted`` (SitlError if taken) or the lowest free one from ``first``."""
    candidates = [int(wanted)] if wanted is not None and int(wanted) >= 0 else range(first, MAX_INSTANCE)
    for n in candidates:
        if not 0 <= n < MAX_INSTANCE:
            raise SitlError(f"instance {n} out of range 0..{MAX_INSTANCE - 1}")
        fd = os.open(_lock_dir() / f"instance-{n}.lock", os.O_CREAT | os.O_RDWR, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EACCES):
                continue
            raise
        if instance_ports_free(n):
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return Instance(n, fd)
        os.close(fd)
    if wanted is not None and int(wanted) >= 0:
        raise SitlError(f"instance {wanted} is in use (its lock or one of its ports {ports(int(wanted))} is taken)")
    raise SitlError(f"no free SITL instance among 0..{MAX_INSTANCE - 1}")


def find_binary(path: str | None) -> str:
    """The SITL executable: ``path`` or else $ARDUPILOT_SITL; a SitlError saying how to provide one."""
    path = (path or "").strip() or os.environ.get(ENV_BINARY, "").strip()
    if not path:
        raise SitlError(f"no ArduPilot SITL binary: set the parameter 'sitl_binary' or the environment variable "
                        f"{ENV_BINARY} to the path of an 'arducopter' SITL build")
    p = Path(path).expanduser()
    if not p.is_file():
        raise SitlError(f"SITL binary not found: {p} (set {ENV_BINARY} or 'sitl_binary' to an 'arducopter' SITL build)")
    if not os.access(p, os.X_OK):
        raise SitlError(f"SITL binary is not executable: {p} (chmod +x it)")
    return str(p.resolve())


def _die_with_parent():
    # runs in the child between fork and exec: SIGKILL when the parent (thread) dies
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


class SitlProcess:
    """Start ``binary`` (an arducopter SITL build) in ``workdir`` on a claimed instance; see the module docstring.

    model     "JSON:127.0.0.1" (lock-step, our physics) or "quad" (SITL's own)
    home      (lat, lon, alt_m, yaw_deg)
    """

    def __init__(self, binary: str, workdir, *, model: str, home, defaults: str | None = None, speedup: float = 1.0,
                 sysid: int = 1, instance: int | None = None, rate: int | None = None, extra_args=()):
        self.binary = find_binary(binary)
        self.workdir = Path(workdir)
        self.model = model
        self.home = tuple(float(v) for v in home)
        self.defaults = defaults
        self.speedup = float(speedup)
        self.sysid = int(sysid)
        self.wanted = instance
        self.rate = rate
        self.extra_args = list(extra_args)
        self.instance: Instance | None = None
        self.proc: subprocess.Popen | None = None
        self._log = None

    @property
    def number(self) -> int:
        return self.instance.number

    @property
    def ports(self) -> dict:
        return ports(self.number)

    @property
    def log_path(self) -> Path:
        return self.workdir / "sitl.log"

    def command(self) -> list[str]:
        lat, lon, alt, yaw = self.home
        cmd = [self.binary, "--model", self.model, "--home", f"{lat!r},{lon!r},{alt!r},{yaw!r}",
               "-I", str(self.number), "--sysid", str(self.sysid), "--speedup", f"{self.speedup:g}", "-w",
               "--start-time", str(START_TIME_UTC)]
        if self.defaults:
            cmd += ["--defaults", str(self.defaults)]
        if self.rate:
            cmd += ["--rate", str(int(self.rate))]
        return cmd + self.extra_args

    def claim(self) -> int:
        """Claim the instance (before start, so that the physics can bind its port first)."""
        if self.instance is None:
            self.instance = claim_instance(self.wanted)
        return self.number

    def start(self) -> None:
        for f in (self.defaults or "").split(","):
            if f and not Path(f).is_file():
                raise SitlError(f"SITL defaults file not found: {f}")
        self.claim()
        self.workdir.mkdir(parents=True, exist_ok=True)
        self._log = open(self.log_path, "ab")
        try:
            self.proc = subprocess.Popen(self.command(), cwd=self.workdir, stdin=subprocess.DEVNULL,
                                         stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True,
                                         preexec_fn=_die_with_parent, close_fds=True)
            _LIVE.add(self)
        except OSError as exc:
            self.stop()
            raise SitlError(f"cannot start SITL {self.binary}: {exc.strerror or exc}") from None

    def exit_reason(self) -> str | None:
        """None while running, else a phrase such as 'SITL exited with code 1' or '... killed by signal 9'."""
        if self.proc is None:
            return "SITL not started"
        rc = self.proc.poll()
        if rc is None:
            return None
        if rc < 0:
            try:
                sig = signal.Signals(-rc).name
            except ValueError:
                sig = str(-rc)
            return f"SITL (pid {self.proc.pid}) was killed by signal {-rc} ({sig}); its log: {self.log_path}"
        return f"SITL (pid {self.proc.pid}) exited with code {rc}; its log: {self.log_path}"

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self, timeout: float = 5.0) -> None:
        """SIGKILL the whole process group (SITL ignores SIGTERM in JSON mode), reap it, free the instance."""
        p = self.proc
        _LIVE.discard(self)
        if p is not None:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            try:
                p.wait(timeout)
            except subprocess.TimeoutExpired:      # pragma: no cover - SIGKILL cannot be ignored
                pass
        if self._log is not None:
            self._log.close()
            self._log = None
        if self.instance is not None:
            self.instance.release()
            self.instance = None

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.stop()

    def __del__(self):
        try:
            self.stop()
        except Exception:   # noqa: BLE001 - interpreter shutdown
            pass


def wait_for_port(port: int, timeout: float, proc: SitlProcess | None = None) -> socket.socket:
    """A TCP connection to 127.0.0.1:port, retried until SITL listens; SitlError on timeout or SITL's death."""
    deadline = time.monotonic() + timeout
    while True:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            s.connect(("127.0.0.1", port))
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            return s
        except OSError:
            s.close()
        if proc is not None and (why := proc.exit_reason()):
            raise SitlError(why)
        if time.monotonic() > deadline:
            raise SitlError(f"SITL does not listen on 127.0.0.1:{port} after {timeout:g} s of wall clock")
        time.sleep(0.02)
