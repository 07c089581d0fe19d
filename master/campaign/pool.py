"""A pool of long-lived worker processes that survives crashing runs.

Each worker is a separate process that imports the master once and runs tasks one after another, so
imports, the FMU cache and pythonfmu's loaded slave classes are paid once per worker, not once per run.
Workers are forked from a fork server (``forkserver``): a clean interpreter started once per process, with no
threads of the caller and no state of a run, that imports the engine once (:data:`PRELOAD`); a worker forked
from it starts warm, in milliseconds instead of the ~0.5 s CPU of a fresh interpreter importing the engine
(``spawn``, the fallback where there is no fork server). The caller's environment variables and working folder
go to each worker as they are when it starts (as with ``spawn``). The parent talks to each worker over its own
pipe and watches the process sentinel:

* a worker that dies while running a task (an FMU calling abort(), a segfault, the OOM killer) is
  detected; the task is reported failed with ``worker process died with signal 6 (SIGABRT)`` (or the
  exit code) and a fresh worker takes its place;
* a task running longer than ``timeout`` seconds gets its worker killed and is reported failed;
* workers ignore SIGINT: Ctrl-C reaches the parent only, which stops every worker (their runs in
  flight are simply not reported) -- so only complete records are ever written;
* on Linux workers ask to be killed when the parent dies (PR_SET_PDEATHSIG), so a killed campaign
  leaves no orphan writing into the campaign folder; a forked worker's parent is the fork server, which exits
  when the campaign process dies (its "alive" pipe closes), so the worker is killed then too;
* each worker unpacks the runs' SSPs into a scratch folder named for its process id (``ssp.archive.UNPACK_DIR``)
  and removes it when it exits; the folder of a worker that died (a run's abort(), a timeout's kill) goes once the
  pool has reaped it, and those of a campaign killed as a whole go when the next campaign starts (master/scratch.py).
"""
from __future__ import annotations

import atexit
import multiprocessing as mp
import os
import shutil
import signal
import tempfile
import time
from collections import deque
from multiprocessing.connection import wait as mp_wait
from typing import Callable, Iterable

from .. import interrupts, scratch
from ..ssp import archive
from . import worker_preload
from .execute import execute_run, failure_record

__all__ = ["WorkerPool", "describe_exit", "PRELOAD", "WORKER_SCRATCH_PREFIX", "sweep_left_worker_scratch"]

#: + the worker's process id: the folder a worker unpacks the runs' SSPs into
WORKER_SCRATCH_PREFIX = "cosim-campaign-worker-"


def sweep_left_worker_scratch(folder: str | None = None) -> list[str]:
    """Removes the scratch folders of workers that are gone (their names); a live worker's stay."""
    return scratch.sweep_left(folder or tempfile.gettempdir(), WORKER_SCRATCH_PREFIX, None)

#: what the fork server imports once for all the workers it forks: the main module (as spawn would import it
#: in each worker) and the run path of a campaign run, with what a worker's first run imports of the engine and
#: fmpy (~60 ms of a first run's CPU), and what the installed scenario kinds' runs import (worker_preload); a name
#: that does not import is skipped
PRELOAD = ["__main__", "master.runner", "master.campaign.execute", "fmpy", "master.fmi.inprocess",
           "master.algorithms.fixed_step", "master.algorithms.compiled", "master.sinks.parquet", "master.sinks.memory",
           "master.campaign.worker_preload"]


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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


def _warm_up():
    """Import the master's run path before the first task comes: a pool started early (``WorkerPool.start``)
    does this on a core that would wait for the parent planning the campaign."""
    try:
        import master.runner  # noqa: F401
    except Exception:   # noqa: BLE001 - the first task reports what is wrong
        pass


def _fork_server_started() -> bool:
    """Start the process's fork server if it is not running (it is kept for every later pool of this process);
    False where there is none (then workers are spawned)."""
    if "forkserver" not in mp.get_all_start_methods():
        return False
    from multiprocessing import forkserver
    import threading
    forkserver.set_forkserver_preload(PRELOAD)     # read only when the server starts
    # the server starts with this environment (a worker gets the caller's own, without it): worker_preload acts there
    os.environ[worker_preload.SERVER_FLAG] = "1"
    try:
        _ensure_server_running(forkserver, threading)
    finally:
        os.environ.pop(worker_preload.SERVER_FLAG, None)
    global _server_owner
    if _server_owner is None:
        _server_owner = os.getpid()
        atexit.register(_stop_fork_server)
    return True


def _ensure_server_running(forkserver, threading) -> None:
    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()
    else:
        # the server keeps the SIGTERM disposition it is started with: ignored, so that a SIGTERM sent to the
        # process group does not kill it (and its workers, through PR_SET_PDEATHSIG) before the campaign has
        # stopped them as it does after Ctrl-C; blocked meanwhile here, so that this process still gets it
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
        previous = signal.signal(signal.SIGTERM, signal.SIG_IGN)
        try:
            forkserver.ensure_running()
        finally:
            signal.signal(signal.SIGTERM, previous)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


_server_owner: int | None = None


def _stop_fork_server():
    """At exit, stop the fork server and wait for it (left alone it exits only after this process, unreaped: its
    CPU and its workers' would be missing from this process's children's time).  The end of its "alive" pipe asks
    it to exit; a child forked from this process may hold a copy of that pipe, so after 2 s it is killed."""
    if _server_owner != os.getpid():       # a forked copy of this process
        return
    from multiprocessing import forkserver
    fs = forkserver._forkserver        # private (the stdlib has no public stop), the same since Python 3.4
    pid, fd = getattr(fs, "_forkserver_pid", None), getattr(fs, "_forkserver_alive_fd", None)
    if pid is None:
        return
    try:
        os.close(fd)
    except (OSError, TypeError):
        pass
    fs._forkserver_alive_fd = fs._forkserver_pid = None
    deadline = time.monotonic() + 2.0
    try:
        while not os.waitpid(pid, os.WNOHANG)[0]:
            if time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                break
            time.sleep(0.01)
    except (ChildProcessError, ProcessLookupError):
        pass
    address = getattr(fs, "_forkserver_address", None)
    if isinstance(address, str) and not address.startswith("\0"):
        try:
            os.unlink(address)
        except OSError:
            pass
    fs._forkserver_address = None


def _leave_fork_server():
    """A forked worker inherits the fork server's "alive" pipe, which would keep the server (and, through
    PR_SET_PDEATHSIG, the worker itself) alive after the campaign process is killed; a worker starts no process
    through the server, so it closes its end."""
    try:
        from multiprocessing import forkserver
        fs = forkserver._forkserver
        if fs._forkserver_alive_fd is not None:
            os.close(fs._forkserver_alive_fd)
            fs._forkserver_alive_fd = None
    except (ImportError, AttributeError, OSError):
        pass


def _worker_main(conn, parent_pid: int, environ: dict | None = None, scratch_root: str | None = None):
    # the parent stops the workers on Ctrl-C and SIGTERM (sent to the whole group by a terminal, `timeout`, systemd):
    # a worker dying of them would record its run as failed
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})   # blocked in the fork server, see above
    if environ is not None:     # forked: the server's environment is the one of its own start
        os.environ.clear()
        os.environ.update(environ)
        _leave_fork_server()
    _pdeathsig()
    if environ is None and os.getppid() != parent_pid:     # spawned: the parent died before prctl took effect
        return
    if environ is not None and not _alive(parent_pid):     # forked: the campaign died before the server's death
        return                                            # could kill this worker
    _warm_up()
    # a run killed with its worker cannot remove its unpacked SSP: it is in this folder, which the pool removes
    archive.UNPACK_DIR = folder = scratch.make(WORKER_SCRATCH_PREFIX, scratch_root)
    first = True
    try:
        while True:
            try:
                task = conn.recv()
            except (EOFError, OSError):
                return
            if task is None:
                return
            rec = execute_run(task)
            if first:
                _freeze_what_stays()
                first = False
            try:
                conn.send(rec)
            except (BrokenPipeError, OSError):
                return
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _freeze_what_stays() -> None:
    """After a worker's first run, what is alive stays for the worker's life (the imports, the FMU cache, the
    structures cached per SSD): frozen (``gc.freeze``), the cyclic collector stops going over it again and again
    in every run's full collections (~3 % of a worker's CPU in the paper campaign). Collected first, so that the
    first run's own garbage is not kept for good."""
    import gc
    gc.collect()
    gc.freeze()


class _Worker:
    def __init__(self, ctx, n: int, scratch_root: str):
        parent, child = ctx.Pipe(duplex=True)
        forked = ctx.get_start_method() == "forkserver"
        args = (child, os.getpid(), dict(os.environ) if forked else None, scratch_root)
        self.proc = ctx.Process(target=_worker_main, args=args, name=f"cosim-campaign-worker-{n}", daemon=True)
        # a stop signal taken inside start() (after the fork server has forked the worker, before the worker's
        # preparation data is written to it) left the new worker reading an empty pipe: multiprocessing printed its
        # EOFError traceback on the campaign's stderr. Held until the worker has what it needs, then taken.
        with interrupts.deferred():
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

    def __init__(self, n: int, timeout: float | None = None, start_method: str = "forkserver"):
        """``start_method``: "forkserver" (falls back to "spawn" where there is none) or "spawn"."""
        self.n = max(1, int(n))
        self.timeout = timeout
        self.ctx = mp.get_context(start_method if start_method != "forkserver" or _fork_server_started()
                                  else "spawn")
        self.started_workers = 0
        self.crashes = 0
        self.scratch_root = tempfile.gettempdir()      # the caller's, as the workers' own may differ (fork server)
        self._ready: list[_Worker] = []
        self._leaving: list[_Worker] = []

    def _new(self) -> _Worker:
        self.started_workers += 1
        if self.ctx.get_start_method() == "forkserver":
            _fork_server_started()      # again if it died (it is started anew with SIGTERM ignored)
        return _Worker(self.ctx, self.started_workers, self.scratch_root)

    def start(self) -> None:
        """Start the workers before the tasks are known: their interpreters start and import the master while
        the caller still plans (``run`` uses them; ``close`` stops those it did not need).  With a fork server
        there is nothing to do: the server imports the master from its start (``__init__``) on, and a fork would
        wait here for that import."""
        if self.ctx.get_start_method() == "forkserver":
            return
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
        sweep_left_worker_scratch(self.scratch_root)      # the folders of workers that died or were killed

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
        sweep_left_worker_scratch(self.scratch_root)      # those of a campaign killed as a whole
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
                        sweep_left_worker_scratch(self.scratch_root)
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
