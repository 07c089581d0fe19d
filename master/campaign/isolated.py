"""Runs in a child process of the caller, for Dask workers: a crashing FMU or a run over its timeout costs
that run, not the Dask worker.

A Dask worker process is daemonic (``distributed.worker.daemon``), so it cannot use multiprocessing
children; :class:`IsolatedRunner` starts ``python -m master.campaign.isolated`` with ``subprocess`` instead
and keeps it for the next run (imports and the FMU cache are paid once per worker thread, as in the local
pool).  Tasks and records travel as length-prefixed pickles over a pipe of their own (an FMU may print to
stdout).  A child that dies gives ``worker process died with signal N (NAME)``, one that exceeds the
timeout is killed and gives ``timed out after T s (worker killed)``: the same records as the local pool.
"""
from __future__ import annotations

import os
import pickle
import select
import signal
import struct
import subprocess
import sys
import threading
import time

from .execute import execute_run, failure_record
from .pool import describe_exit

__all__ = ["IsolatedRunner", "run_isolated"]

_HEADER = struct.Struct("!Q")


def _read_exact(fd: int, n: int, deadline: float | None) -> bytes | None:
    """n bytes from fd, or None if the deadline passes or the pipe closes first."""
    chunks, got = [], 0
    while got < n:
        if deadline is not None:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                return None
        data = os.read(fd, min(n - got, 1 << 20))
        if not data:
            return None
        chunks.append(data)
        got += len(data)
    return b"".join(chunks)


def _write_msg(fd: int, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


class IsolatedRunner:
    """One long-lived child process that runs campaign tasks one after another."""

    def __init__(self):
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "master.campaign.isolated", str(to_child_r), str(from_child_w)],
            pass_fds=(to_child_r, from_child_w), stdin=subprocess.DEVNULL)
        os.close(to_child_r)
        os.close(from_child_w)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def run(self, task: dict, timeout: float | None = None) -> tuple[dict, bool]:
        """(record, child still usable)."""
        t0 = time.monotonic()
        worker = f"pid {self.proc.pid}"
        try:
            _write_msg(self._to_child, task)
        except OSError:
            self.close()
            return failure_record(task, describe_exit(self.proc.poll()), 0.0, worker), False
        deadline = t0 + timeout if timeout else None
        head = _read_exact(self._from_child, _HEADER.size, deadline)
        body = _read_exact(self._from_child, _HEADER.unpack(head)[0], None) if head else None
        if body is not None:
            return pickle.loads(body), True
        elapsed = time.monotonic() - t0
        if deadline is not None and time.monotonic() >= deadline and self.alive():    # over its time
            self.close()
            return failure_record(task, f"timed out after {timeout:g} s (worker killed)", elapsed, worker), False
        try:                       # the pipe closed: the child is dying (it may not have exited yet)
            code = self.proc.wait(10)
        except subprocess.TimeoutExpired:
            code = None
        self.close()
        return failure_record(task, describe_exit(code), elapsed, worker), False

    def close(self):
        if self.alive():
            self.proc.kill()
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:   # pragma: no cover - a kill that did not take
            pass
        for fd in (self._to_child, self._from_child):
            try:
                os.close(fd)
            except OSError:
                pass


_runners: dict = {}
_lock = threading.Lock()


def run_isolated(task: dict) -> dict:
    """Run ``task`` in this thread's child process (started on first use, replaced after a crash or a
    timeout); the task's own ``timeout`` option applies.  Used as the Dask task function."""
    key = (os.getpid(), threading.get_ident())
    with _lock:
        runner = _runners.get(key)
        if runner is None or not runner.alive():
            runner = _runners[key] = IsolatedRunner()
    timeout = (task.get("options") or {}).get("timeout")
    rec, usable = runner.run(task, float(timeout) if timeout else None)
    if not usable:
        with _lock:
            _runners.pop(key, None)
    return rec


def _child_main(read_fd: int, write_fd: int) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        head = _read_exact(read_fd, _HEADER.size, None)
        if head is None:
            return 0
        task = pickle.loads(_read_exact(read_fd, _HEADER.unpack(head)[0], None))
        _write_msg(write_fd, execute_run(task))


if __name__ == "__main__":
    sys.exit(_child_main(int(sys.argv[1]), int(sys.argv[2])))
