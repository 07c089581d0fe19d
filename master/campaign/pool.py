"""A pool of long-lived worker processes that survives crashing runs.

Each worker is a separate process (``spawn``: a clean interpreter, no inherited threads) that imports
the master once and runs tasks one after another, so imports, the FMU cache and pythonfmu's loaded
slave classes are paid once per worker, not once per run.  The parent talks to each worker over its
own pipe and watches the process sentinel:

* a worker that dies while running a task (an FMU calling abort(), a segfault, the OOM killer) is
  detected; the task is reported failed with ``worker process died with signal 6 (SIGABRT)`` (or the
  exit code) and a fresh worker takes its place;
* a task running longer than ``timeout`` seconds gets its worker killed and is reported failed;
* workers ignore SIGINT: Ctrl-C reaches the parent only, which stops every worker (their runs in
  flight are simply not reported) -- so only complete records are ever written;
* on Linux workers ask to be killed when the parent dies (PR_SET_PDEATHSIG), so a killed campaign
  leaves no orphan writing into the campaign folder.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time
from collections import deque
from multiprocessing.connection import wait as mp_wait
from typing import Callable, Iterable

from .execute import execute_run, failure_record

__all__ = ["WorkerPool", "describe_exit"]


def describe_exit(exitcode: int | None) -> str:
    if exitcode is None:
        return "worker process died"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"worker process died with signal {-exitcode} ({name})"
    return f"worker process exited with code {exitcode}"


def _pdeathsig():
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)      # PR_SET_PDEATHSIG
    except Exception:   # noqa: BLE001 - best effort, Linux only
        pass


def _warm_up():
    """Import the master's run path before the first task comes: a pool started early (``WorkerPool.start``)
    does this on a core that would wait for the parent planning the campaign."""
    try:
        import master.runner  # noqa: F401
    except Exception:   # noqa: BLE001 - the first task reports what is wrong
        pass


def _worker_main(conn, parent_pid: int):
    # the parent stops the workers on Ctrl-C and SIGTERM (sent to the whole group by a terminal, `timeout`, systemd):
    # a worker dying of them would record its run as failed
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _pdeathsig()
    if os.getppid() != parent_pid:     # the parent died before prctl took effect
        return
    _warm_up()
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        rec = execute_run(task)
        try:
            conn.send(rec)
        except (BrokenPipeError, OSError):
            return


class _Worker:
    def __init__(self, ctx, n: int):
        parent, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=_worker_main, args=(child, os.getpid()), name=f"cosim-campaign-worker-{n}",
                                daemon=True)
        self.proc.start()
        child.close()
        self.conn = parent
        self.task: dict | None = None
        self.started = 0.0

    def send(self, task: dict):
        self.task = task
        self.started = time.monotonic()
        self.conn.send(task)

    def ask_to_stop(self):
        try:
            self.conn.send(None)
        except (BrokenPipeError, OSError):
            pass

    def kill(self):
        if self.proc.is_alive():
            self.proc.kill()
        self.proc.join(5)
        try:
            self.conn.close()
        except OSError:
            pass


class WorkerPool:
    """Run tasks on ``n`` worker processes; ``on_result(record)`` is called in the parent as each finishes."""

    def __init__(self, n: int, timeout: float | None = None, start_method: str = "spawn"):
        self.n = max(1, int(n))
        self.timeout = timeout
        self.ctx = mp.get_context(start_method)
        self.started_workers = 0
        self.crashes = 0
        self._ready: list[_Worker] = []
        self._leaving: list[_Worker] = []

    def _new(self) -> _Worker:
        self.started_workers += 1
        return _Worker(self.ctx, self.started_workers)

    def start(self) -> None:
        """Start the workers before the tasks are known: their interpreters start and import the master while
        the caller still plans (``run`` uses them; ``close`` stops those it did not need)."""
        while len(self._ready) < self.n:
            self._ready.append(self._new())

    def close(self, timeout: float = 2.0) -> None:
        """Stop the workers started by ``start`` that no ``run`` took (killed, as they hold nothing yet: a polite
        stop would wait for their start-up imports) and wait for those ``run`` let go."""
        self._kill_spares()
        deadline = time.monotonic() + timeout
        while self._leaving:
            w = self._leaving.pop()
            w.proc.join(max(0.0, deadline - time.monotonic()))
            w.kill()

    def _kill_spares(self) -> None:
        while self._ready:
            self._ready.pop().kill()

    def _let_go(self, w: _Worker) -> None:
        """No more work for ``w``: it exits now (interpreter teardown, its FMU temp folders: ~0.2 s) while the
        others finish their runs; ``close`` waits for it."""
        w.ask_to_stop()
        self._leaving.append(w)

    def _first(self, task: dict) -> _Worker:
        """A worker started early, or a new one, running ``task``."""
        while self._ready:
            w = self._ready.pop(0)
            try:
                w.send(task)
                return w
            except (BrokenPipeError, OSError):     # it died while waiting: its task would be blamed on this one
                w.kill()
        w = self._new()
        w.send(task)
        return w

    def run(self, tasks: Iterable[dict], on_result: Callable[[dict], None], wait: bool = True) -> None:
        """``wait``: return once every worker has exited (else ``close`` waits for them: the caller may go on,
        e.g. write the table, while they exit; they write nothing more)."""
        queue = deque(tasks)
        workers: list[_Worker] = []
        try:
            for _ in range(min(self.n, len(queue))):
                workers.append(self._first(queue.popleft()))
            self._kill_spares()
            while any(w.task is not None for w in workers):
                busy = [w for w in workers if w.task is not None]
                waitables = [w.conn for w in busy] + [w.proc.sentinel for w in busy]
                timeout = None
                if self.timeout:
                    now = time.monotonic()
                    timeout = max(0.05, min(w.started + self.timeout - now for w in busy))
                ready = set(mp_wait(waitables, timeout))
                for w in busy:
                    rec = None
                    dead = False
                    if w.conn in ready or w.proc.sentinel in ready:
                        try:
                            if w.conn.poll():
                                rec = w.conn.recv()
                        except (EOFError, OSError):
                            rec = None
                        if rec is None:
                            w.proc.join(5)
                            rec = failure_record(w.task, describe_exit(w.proc.exitcode),
                                                 time.monotonic() - w.started, f"pid {w.proc.pid}")
                            dead = True
                    elif self.timeout and time.monotonic() - w.started > self.timeout:
                        rec = failure_record(w.task, f"timed out after {self.timeout:g} s (worker killed)",
                                             time.monotonic() - w.started, f"pid {w.proc.pid}")
                        dead = True
                    if rec is None:
                        continue
                    w.task = None
                    if dead:
                        self.crashes += 1
                        w.kill()
                        workers.remove(w)
                    # the next task first: the parent's bookkeeping of this record (an fsync'ed write, the
                    # progress bar) would otherwise keep the worker idle
                    if queue:
                        if dead:
                            w = self._new()
                            workers.append(w)
                        w.send(queue.popleft())
                    elif not dead:
                        workers.remove(w)
                        self._let_go(w)
                    on_result(rec)
        finally:
            for w in workers:
                if w.task is None:
                    self._let_go(w)
                else:
                    w.kill()      # interrupted: its run is not reported
            self._kill_spares()
            if wait:
                self.close()
