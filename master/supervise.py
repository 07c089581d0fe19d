"""A supervised run: the simulation in a child process, the results in this one.

An FMU is foreign code in the master's address space: it can abort, segfault or never return. So the
``cosim-master run`` command runs the simulation (``Execution``) in a forked child and keeps the outputs here:

* the child records its rows into a block in shared memory; a full block is handed over there (the child says
  through the pipe how many rows it holds and waits until this process has copied them out) and this process
  writes it to the sinks (Parquet, CSV); the rows of the block being filled are in shared memory too, so the
  rows recorded before a crash are all kept, whatever kills the child;
* events are sent as they happen; the child's run.json facts come at its end;
* a crash (signal), ``--timeout`` (wall clock) or Ctrl-C/SIGTERM that the child does not answer within
  ``GRACE_S`` ends with the child killed, its rows written, run.json saying what happened, and the component
  named: the child's faulthandler dumps its Python stack on a fatal signal and on SIGUSR1 (sent before a kill),
  and the line of the compiled step it was in tells which component's FMI call it was; in the native step
  loop and outside the step loop a shared probe tells the phase and component.

The native step loop (drivers/native.py) runs in the child too: it keeps the header as the Python path
does (time reached, rows) and writes the index of the component whose FMI call it is in before each call, so
a crash there names the same component and time.

Shared memory layout (float64): [blocks sent, rows in the current block, time of the last row, time reached,
phase, component index, component in an FMI call of the native loop (-1: none), unused] then the block
(rows x columns). The child makes it (a file in /dev/shm named for the supervisor's process id) and goes on; the
parent maps it and removes the name, and sweeps the names that killed runs left (``_sweep_left_blocks``).
"""
from __future__ import annotations

import contextlib
import faulthandler
import gc
import mmap
import os
import pickle
import re
import select
import shutil
import signal
import struct
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from . import execution, scratch
from .cache_paths import fmpy_validator
from .errors import CosimError, Terminated
from .execution import Execution, Options, platform_name, write_run_files
from .observers.recording import Recording, block_table, schema_of
from .results import claim_output_folder, release_output_folder, settle_output_folder
from .runtime import PHASE_NAMES, PHASE_STEP
from .sinks import BUILTIN_SINKS, SINKS
from .sinks.base import Sink
from .sinks.group import SinkGroup, write_failure
from .ssp import archive

HEADER = 8
H_BLOCKS, H_FILL, H_LAST_ROW, H_TIME, H_PHASE, H_COMPONENT, H_NATIVE = range(7)
GRACE_S = 3.0                    # how long a child may take to stop after Ctrl-C/SIGTERM before it is killed
ORPHAN_GRACE_S = 5.0             # how long an orphaned child's main thread gets to notice before its watchdog acts
PARENT_DEATH_SIGNAL = signal.SIGUSR2
FINISH_S = 120.0                 # how long a child that has ended its simulation may take to write its products
TURN_S = 0.05                    # the most time the supervisor spends on messages before its stop checks
CRASH_FILE = ".cosim-master.stack"
SIGNAL_NAMES = {int(s): s.name for s in signal.Signals}
#: this process is the command's own (set by the CLI, ``cli._import_command``): the supervisor may freeze what it
#: imports (``gc.freeze``), which a caller's process (the API, a test) must not have done to its objects
OWN_PROCESS = False


# ------------------------------------------------------------------------------------- the two processes
class _Channel:
    """One end of the two-way message channel between the supervisor and its child: each message pickled and
    sent after its length, over two pipes. What multiprocessing's Pipe does over a socket pair, without importing
    multiprocessing and socket, ~4 ms of CPU before the fork that the run's start-up paid for nothing else.
    ``recv`` raises EOFError once the other end is closed (also in the middle of a message)."""
    def __init__(self, read_fd: int, write_fd: int):
        self.read_fd, self.write_fd = read_fd, write_fd

    def fileno(self) -> int:
        return self.read_fd

    def send(self, msg) -> None:
        data = pickle.dumps(msg, pickle.HIGHEST_PROTOCOL)
        view = memoryview(struct.pack("!Q", len(data)) + data)
        while view:
            view = view[os.write(self.write_fd, view):]

    def _read(self, n: int) -> bytes:
        parts = []
        while n:
            part = os.read(self.read_fd, n)
            if not part:
                raise EOFError("the other process closed the channel")
            parts.append(part)
            n -= len(part)
        return b"".join(parts)

    def recv(self):
        return pickle.loads(self._read(struct.unpack("!Q", self._read(8))[0]))

    def poll(self, timeout: float = 0.0) -> bool:
        return bool(_ready([self], timeout))

    def close(self) -> None:
        for fd in (self.read_fd, self.write_fd):
            if fd is not None:
                os.close(fd)
        self.read_fd = self.write_fd = None


def _channel_pair() -> tuple[_Channel, _Channel]:
    """The supervisor's end and the child's, each closed in the other process after the fork."""
    to_parent_r, to_parent_w = os.pipe()
    to_child_r, to_child_w = os.pipe()
    return _Channel(to_parent_r, to_child_w), _Channel(to_child_r, to_parent_w)


def _ready(objects: list, timeout: float | None) -> list:
    """Those of ``objects`` (channels, file descriptors) with something to read or whose other end is closed,
    waiting up to ``timeout`` seconds (None: until one is)."""
    fds = {(o if isinstance(o, int) else o.fileno()): o for o in objects}
    poller = select.poll()
    for fd in fds:
        poller.register(fd, select.POLLIN)
    return [fds[fd] for fd, _ in poller.poll(None if timeout is None else timeout * 1000.0)]


class _ForkedChild:
    """The simulation process, forked to run ``target(*args)`` (which ends with ``os._exit``). ``sentinel``: a file
    descriptor that becomes readable when the process has ended (it holds the pipe's other end until then), as a
    multiprocessing Process's; ``exitcode`` after ``join``: the exit status, or minus the signal that killed it."""
    def __init__(self, target, args: tuple):
        self.target, self.args = target, args
        self.pid: int | None = None
        self.sentinel: int | None = None
        self.exitcode: int | None = None

    def start(self) -> None:
        for stream in (sys.stdout, sys.stderr):     # else what they hold would be written by both processes
            try:
                stream.flush()
            except (AttributeError, OSError, ValueError):
                pass
        sentinel, held = os.pipe()
        pid = os.fork()
        if pid == 0:
            try:
                os.close(sentinel)
                _stdin_to_devnull()
                self.target(*self.args)
            except BaseException:   # noqa: BLE001 - the target did not get to its own exit: say why, as it is
                import traceback
                traceback.print_exc()
            finally:
                os._exit(1)
        os.close(held)
        self.pid, self.sentinel = pid, sentinel

    def kill(self) -> None:
        if self.exitcode is None:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass

    def join(self) -> None:
        if self.exitcode is None:
            _, status = os.waitpid(self.pid, 0)
            self.exitcode = os.waitstatus_to_exitcode(status)
            os.close(self.sentinel)


def _stdin_to_devnull() -> None:
    """The child reads nothing from the terminal (as a multiprocessing child): its stdin is /dev/null."""
    if sys.stdin is not None:
        try:
            sys.stdin.close()
            sys.stdin = open(os.devnull)
        except (OSError, ValueError):
            pass


# ------------------------------------------------------------------------------------------------ child
class _RowsInSharedMemory:
    """What the child hands over for a full block: only its row count. The rows themselves are already where the
    parent reads them, in the shared block (``_PipeSink``)."""
    __slots__ = ("num_rows",)

    def __init__(self, num_rows: int):
        self.num_rows = num_rows


class _PipeSink(Sink):
    """The child's one sink: a full block is handed to the parent through the shared block it was filled in. The
    child says how many rows it holds and waits until the parent has taken its own copy (``_Supervisor.handle``),
    then fills the block again. The rows cross once, as one copy in the parent; sending them as Arrow IPC through
    the pipe cost ~0.5 s of CPU for 200,000 rows of 120 values (IPC buffer, bytes, pickle, the pipe in and out,
    and a fresh block's page faults each time)."""
    needs_folder = False

    def __init__(self, conn, header):
        self.conn, self.header = conn, header
        self.sent = 0
        self.last = False       # the recording's last block: nothing fills the shared block after it
        self.untaken = False    # the parent's word for the last block is still to be read

    def write(self, block):
        _send(self.conn, ("block", block.num_rows))
        self.sent += 1
        if self.last:           # not filled again: the child goes on to its end at once
            self.untaken = True
        else:
            _wait_taken(self.conn)
        # order matters for the parent's recovery: the rows left in shared memory count only once the block
        # count says they are not the block just sent
        self.header[H_FILL] = 0
        self.header[H_BLOCKS] = self.sent


def _wait_taken(conn):
    """Waits for the parent's word that it has copied the block out of shared memory (the only message the parent
    sends while the child records). Interrupts are held as for a send: one taken in the middle left the word unread
    and the child reading it as the answer to its next question."""
    signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        reply = conn.recv()
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)
    if reply[0] != "taken":
        raise RuntimeError(f"the supervising process answered {reply[0]!r} to a block")


class _ChildRecording(Recording):
    results_read_after = True       # something finishing after the recording reads the result files (_child says)

    def __init__(self, base: Recording, conn, out_dir: Path):
        super().__init__(base.variables, [], None, every=base.every, steps=base.steps, block_rows=base.block_rows)
        self.conn = conn
        self.block_folder = out_dir         # where the shared block goes on a system without /dev/shm

    def _new_block(self, rows, cols):
        # made here and named to the parent, which maps it and removes the name: the child goes on at once (it
        # waited for the parent to make it, a hand-over that a busy parent, or a loaded machine, made long)
        self._mm, path = _make_shared_block(rows, cols, self.block_folder)
        self.header = np.ndarray((HEADER,), dtype=np.float64, buffer=self._mm)
        self.header[:] = 0.0
        self.header[H_COMPONENT] = self.header[H_NATIVE] = -1
        _send(self.conn, ("schema", self.columns, rows, cols, path))   # as plain data
        self.group = SinkGroup([_PipeSink(self.conn, self.header)], None)
        return np.ndarray((rows, cols), dtype=np.float64, buffer=self._mm, offset=HEADER * 8)

    def _open_sinks(self):
        self.group.open(None)       # the pipe needs no schema: the parent makes its own from the columns

    def attach(self, ctx, start):
        super().attach(ctx, start)
        ctx.rt.probe = self.header[H_PHASE:H_COMPONENT + 1]
        self.header[H_PHASE] = PHASE_STEP

    def native_progress(self) -> dict:
        """Where the native loop reports what after_step and sample report here (drivers/native.py PROGRESS_SLOTS);
        by offering it this recording lets the loop run its steps in C. The parent is told, for the run.json
        of a child that dies."""
        _send(self.conn, ("native_loop",))
        h = self.header
        return {"time_reached": h[H_TIME:H_TIME + 1], "last_row": h[H_LAST_ROW:H_LAST_ROW + 1],
                "rows": h[H_FILL:H_FILL + 1], "busy": h[H_NATIVE:H_NATIVE + 1]}

    def after_step(self, n, t0, t1):
        self.header[H_TIME] = t1
        if self.algorithm.current_step is not self._step_sent:      # rebuilt after a component was taken out
            self.send_names()
        super().after_step(n, t0, t1)

    def send_names(self):
        self._step_sent = self.algorithm.current_step
        _send(self.conn, ("names", list(self.rt.names), _step_lines(self._step_sent)))

    def _table(self):
        return _RowsInSharedMemory(self.fill)       # the parent builds the table from the shared block

    def flush(self):
        self.header[H_FILL] = self.fill       # the row that filled the block counts if the send is cut short
        super().flush()

    def finish(self, out_dir, outcome):
        # the simulation is over: no component's call is running now (the probe would still name the last one)
        if self.header is not None:
            self.header[H_PHASE], self.header[H_COMPONENT], self.header[H_NATIVE] = 0, -1, -1
            self.group.sinks[0].last = True
        info = super().finish(out_dir, outcome)
        # monitors read results.parquet when they finish (e.g. the UAV trajectory): wait until it is complete; a run
        # with nothing that finishes after the recording goes on (one hand-over between the processes fewer)
        _send(self.conn, ("close", self.results_read_after))
        if self.results_read_after:
            if self.header is not None and self.group.sinks[0].untaken:
                _wait_taken(self.conn)      # (the parent answers in order: the last block's word comes first)
            reply = self.conn.recv()
            info.update(reply[1])
        return info

    def sample(self, t):
        if self.str_:       # before the row: the row that fills a block sends the block, whose table needs it
            _send(self.conn, ("str", self.object_row()))
        super().sample(t)
        self.header[H_LAST_ROW] = t
        self.header[H_FILL] = self.fill


def _make_shared_block(rows: int, cols: int, fallback_folder: Path) -> tuple[mmap.mmap, str]:
    """The shared block (header and rows x cols cells, zeros) mapped here, and its file's path. The name holds the
    supervisor's process id (this process's parent): if both are killed before the parent has removed the name, a
    later run sees whose block it was (_sweep_left_blocks). No room for it (a full /dev/shm, a file size limit) is
    the run's error, as a full disk is: no row is recorded."""
    folder = SHARED_FOLDER if os.path.isdir(SHARED_FOLDER) else str(fallback_folder)
    fd, path = tempfile.mkstemp(prefix=f"{BLOCK_PREFIX}{os.getppid()}-", dir=folder)
    try:
        os.ftruncate(fd, (HEADER + rows * cols) * 8)
        return mmap.mmap(fd, 0), path
    except OSError as exc:
        os.unlink(path)
        raise CosimError(write_failure(exc, path), element="results") from None
    finally:
        os.close(fd)


class _SentEvents(list):
    def __init__(self, conn):
        super().__init__()
        self.conn = conn

    def append(self, event):
        super().append(event)
        _send(self.conn, ("event", event))


def _step_lines(fn) -> dict:
    """Line of the compiled step -> component it calls (``d3(...)``, ``s3_0()``, ``g3_1()``, ``x3_0()``)."""
    out = {}
    for k, line in enumerate(getattr(fn, "source", "").splitlines(), start=1):
        m = re.search(r"\b[dsgxp](\d+)(?:_\d+)?\(", line)
        if m:
            out[k] = int(m.group(1))
    return out


_HELD = {signal.SIGINT, signal.SIGTERM}


def _send(conn, msg):
    """One whole message: an interrupt raised in the middle of a send left the parent waiting for the rest of a
    cut message while this process waited for the parent's answer to its next one (a deadlock under SIGTERM to
    the process group). The interrupt is held for the send and taken right after it."""
    signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        conn.send(msg)
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)


def _stop_run(signum, frame):
    """The child's first Ctrl-C or SIGTERM ends its run in order; from this moment on both are ignored, as the
    close must finish. SIGTERM to the process group reaches the child twice (directly, and forwarded by its
    supervisor): a second one that came after the first was raised but before the handling clause ignored further
    ones raised again there, past it, and the child ended with status 1 and no run.json of its own (one run in
    several hundred under load)."""
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


class ParentGone(KeyboardInterrupt):
    """The supervising process died (``kill -9``): nobody reads the pipe or writes the results any more."""


_parent_died = False     # the parent-death signal came (getppid may still name the parent for a moment)


def _parent_gone(signum, frame):
    global _parent_died
    _parent_died = True
    raise ParentGone()


def _watch_parent(parent_pid: int, out_dir: Path, ex) -> None:
    """Ask the kernel for PARENT_DEATH_SIGNAL when the parent dies and check that it has not died already (a
    parent killed before prctl took effect); a watchdog thread covers a main thread stuck in an FMU's C code,
    which runs no Python signal handler: it writes what can be written and ends the process (a SITL started by
    it goes with it, by its own parent-death signal)."""
    import ctypes
    signal.signal(PARENT_DEATH_SIGNAL, _parent_gone)
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, int(PARENT_DEATH_SIGNAL), 0, 0, 0)   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):       # not Linux: the watchdog alone
        pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(0.2)
        time.sleep(ORPHAN_GRACE_S)
        _orphan_close(out_dir, ex)          # the main thread did not get there: it is stuck
        os._exit(1)
    threading.Thread(target=watch, name="cosim-master-parent-watch", daemon=True).start()


_orphan_lock = threading.Lock()      # taken once, never given back: a second caller waits for the end


def _orphan_close(out_dir: Path, ex) -> None:
    """The parent died with the results half written: make them readable from this side. The CSV the parent
    wrote is cut to its last whole line, the rows of this process's unsent block are added when they follow on
    from it, the Parquet file (no footer) is rebuilt from the CSV, and run.json says what happened. Runs once."""
    _orphan_lock.acquire()
    if threading.current_thread() is threading.main_thread():
        signal.signal(PARENT_DEATH_SIGNAL, signal.SIG_IGN)
    try:
        _write_orphan_results(out_dir, ex)
    except BaseException:   # noqa: BLE001 - nothing more to be done for a run nobody waits for
        pass


def _write_orphan_results(out_dir: Path, ex) -> None:
    from .sinks.group import RESERVE_NAME
    (out_dir / RESERVE_NAME).unlink(missing_ok=True)
    rec = ex.recording if isinstance(ex.recording, _ChildRecording) else None
    meta = dict(ex.metadata)
    if meta.get("platform", "") is None:        # left to the parent, which is gone (execution.platform_name)
        import platform
        meta["platform"] = platform.platform()
    rows, notes = None, []
    try:
        rows = _orphan_rows(out_dir, rec, notes)
    except Exception as exc:   # noqa: BLE001 - run.json still says what happened
        notes.append(f"the results could not be made whole: {exc}")
    (out_dir / CRASH_FILE).unlink(missing_ok=True)
    meta["outcome"] = "interrupted"
    meta["error"] = str(CosimError("the supervising cosim-master process died (killed?); the simulation process "
                                   "wrote what it could and stopped", time=meta.get("last_time")))
    if rows is not None:
        meta["rows_recorded"] = rows
    if notes:
        meta["results_notes"] = notes
    meta["supervised"] = {"parent_died": True}
    meta.setdefault("wall_time_s", None)
    write_run_files(out_dir, meta, list(ex.events))
    settle_output_folder(out_dir, bool(rows))


def _orphan_rows(out_dir: Path, rec, notes: list) -> int | None:
    """The CSV cut to whole lines (plus this process's unsent rows), the Parquet file rebuilt from it; the rows."""
    from .sinks.csv import CsvSink
    from .sinks.parquet import ParquetSink
    csv_path, pq_path = out_dir / CsvSink.file_name, out_dir / ParquetSink.file_name
    rows = None
    if csv_path.is_file():
        rows = _cut_to_whole_lines(csv_path)
        if rec is not None and rows == rec.rows_written and getattr(rec, "fill", 0) and rec.block is not None:
            csv = CsvSink()
            csv.path, csv._fh = csv_path, open(csv_path, "ab", buffering=0)
            try:
                csv.write(block_table(rec.schema, rec.block[:rec.fill], rec.str_rows))
                rows += rec.fill
                notes.append(f"{rec.fill} rows not yet sent to the parent written by the simulation process")
            finally:
                csv.close()
    if pq_path.is_file() and rec is not None:
        try:
            import pyarrow.parquet as pq
            readable = pq.ParquetFile(str(pq_path)).metadata.num_rows == rows
        except Exception:   # noqa: BLE001 - no footer: the parent died while writing it
            readable = False
        if not readable:
            parquet = ParquetSink()
            parquet.path = pq_path
            csv = CsvSink()
            csv.path = csv_path
            sinks = [parquet] + ([csv] if rows is not None else [])
            notes.append(parquet.repair(sinks, rec.schema, rows or 0))
    return rows


def _cut_to_whole_lines(path: Path) -> int:
    """Cuts a CSV after its last complete line; returns its rows (lines after the header)."""
    lines = 0
    last_newline = -1
    with open(path, "rb+") as fh:
        pos = 0
        while True:
            chunk = fh.read(1 << 22)
            if not chunk:
                break
            n = chunk.count(b"\n")
            if n:
                lines += n
                last_newline = pos + chunk.rindex(b"\n")
            pos += len(chunk)
        fh.truncate(last_newline + 1)
    return max(0, lines - 1)


def _child(conn, parent_end, parent_pid: int, scenario, options: dict, scratch: str):
    # the parent's end of the pipe, held here too, kept the pipe open after the parent died: every send then
    # blocked for ever on a pipe nobody read
    parent_end.close()
    # the unpacked SSP goes into a folder the supervisor removes when this process is gone: a child that crashes,
    # or is killed after its grace, cannot remove its own (only that: other temporary files, such as the SITL
    # instance locks every process must see, stay where they are)
    archive.UNPACK_DIR = scratch
    out_dir = Path(options["output"])
    stack = open(out_dir / CRASH_FILE, "w", buffering=1)
    faulthandler.enable(file=stack, all_threads=False)
    faulthandler.register(signal.SIGUSR1, file=stack, all_threads=False)
    execution.PLATFORM_FROM_PARENT = True
    ex = Execution(scenario, **options)
    ex.write_run_json = False        # this process's parent writes run.json (and has claimed the folder)
    ex.sinks_elsewhere = True        # ... and the results (this process needs no pyarrow)
    _watch_parent(parent_pid, out_dir, ex)
    status = 1
    # a forked child starts with the parent's handlers, which only note the signal there: the child's own
    # interrupts end its run in order (its run.json, every row), as in an unsupervised run
    signal.signal(signal.SIGINT, _stop_run)
    signal.signal(signal.SIGTERM, _stop_run)

    def orphaned():
        return _parent_died or os.getppid() != parent_pid
    try:
        _import_fmpy_frozen()
        ex.setup()
        rec = _ChildRecording(ex.recording, conn, out_dir)
        ex.observers[ex.observers.index(ex.recording)] = rec
        ex.recording = rec
        ex.events = _SentEvents(conn)
        rec.algorithm = ex.algorithm
        rec._step_sent = None
        rec.results_read_after = bool(ex.monitors or ex.extra_observers or ex.live_observers)
        ex.initialize()
        rec.send_names()
        ex.simulate_until()
        ex.close("completed")
        status = 0
    except ParentGone:
        pass
    except CosimError as exc:
        if not orphaned():
            ex.close("error", exc)
    except KeyboardInterrupt as exc:
        for s in (signal.SIGINT, signal.SIGTERM):      # one interrupt is enough: the close must finish
            signal.signal(s, signal.SIG_IGN)
        sigterm = isinstance(exc, Terminated)
        why = "stopped by SIGTERM" if sigterm else "interrupted by the user"
        if ex.closed and ex.metadata.get("outcome") == "completed":
            status = 0      # it came while the completed run was written, which it held back: nothing was cut
        else:
            if not orphaned():
                ex.close("interrupted", CosimError(why, time=ex.metadata.get("last_time")))
            status = 143 if sigterm else 130
    except BaseException as exc:  # noqa: BLE001 - a bug must still leave run.json
        if not orphaned():
            ex.close("error", CosimError(f"{type(exc).__name__}: {exc}"))
    finally:
        try:
            signal.signal(PARENT_DEATH_SIGNAL, signal.SIG_IGN)       # from here on the parent is asked, not told
            if not orphaned():
                # with the status this process is about to exit with: the parent writes run.json while the kernel
                # tears this process down (_Supervisor.run), and corrects it if the status turns out otherwise
                _send(conn, ("meta", ex.metadata, ex.events[:] if isinstance(ex.events, list) else [], status))
                conn.close()
        except BaseException:   # noqa: BLE001 - a dying parent: its pipe breaks before the kernel reparents us
            deadline = time.monotonic() + 2.0
            while not orphaned() and time.monotonic() < deadline:
                time.sleep(0.01)
        try:
            if orphaned():
                _orphan_close(out_dir, ex)
        finally:
            stack.close()
            # no exit-time destructors: some FMU binaries (pythonfmu 0.7) crash in them after the run is done
            os._exit(status)


def _import_fmpy_frozen() -> None:
    """fmpy, which every run imports first (it reads the FMUs and names the validator of the validation records,
    ``cache_paths.fmpy_validator``), imported with the cyclic collector off and then frozen, as the CLI does with
    the engine before the fork: its modules live as long as this process, and the ~10 collections its import set
    off (~2-3 ms, on a short run's critical path) examined them over and over."""
    with _loaded_frozen():
        try:
            fmpy_validator()
        except ImportError:     # the run says what is missing where it needs it
            pass


@contextlib.contextmanager
def _loaded_frozen(active: bool = True):
    """What is made inside (modules that live as long as the process) with the cyclic collector off, then frozen
    (``gc.freeze``: never examined again) and the collector back as it was, as the CLI does with its imports before
    the fork (``cli._import_command``); nothing happens unless ``active``. The collections an import sets off go
    over the same long-lived objects again and again, and on a short run they are on its critical path."""
    collecting = gc.isenabled()
    if active:
        gc.disable()
    try:
        yield
    finally:
        if active:
            gc.freeze()
            if collecting:
                gc.enable()


# ----------------------------------------------------------------------------------------------- parent
SHARED_FOLDER = "/dev/shm"
BLOCK_PREFIX = "cosim-master-"
UNNAMED_BLOCK_AGE_S = 3600.0
SCRATCH_PREFIX = "cosim-master-run-"     # + the supervisor's (unsupervised: the run's) process id: the unpacked SSP


def _sweep_left_blocks(folder: str = SHARED_FOLDER) -> list[str]:
    """Removes the shared blocks of supervisors that are gone; returns their names. A block lives under its name only
    from the child's making it until the supervisor has mapped it, but a run killed with SIGKILL in between (both
    processes) left it in /dev/shm for good. The name holds the supervisor's process id: a block whose process still
    runs is left alone. One whose name holds none (an earlier version's, named for no one) goes once it is older
    than ``UNNAMED_BLOCK_AGE_S``: such a block, too, had its name for milliseconds only."""
    return _sweep_left(folder, BLOCK_PREFIX, UNNAMED_BLOCK_AGE_S)


def _sweep_left_scratch(folder: str | None = None) -> list[str]:
    """Removes the scratch folders (the child's unpacked SSP) of supervisors that are gone: a supervisor killed with
    SIGKILL cannot remove its own. Only folders named for a process id: the temporary folder is everyone's."""
    return _sweep_left(folder or tempfile.gettempdir(), SCRATCH_PREFIX, None)


class ScratchFolder:
    """``with ScratchFolder():`` an unsupervised run in this process unpacks its SSP into a folder named for this
    process (``ssp.archive.UNPACK_DIR``, as a supervised run's child does), removed on leaving; a run killed with
    SIGKILL cannot remove it, and the next run sweeps it (``_sweep_left_scratch``). The sweep lists the temporary
    folder, which on a busy machine holds thousands of entries (~2 ms): it comes after the run, whose results are
    then written."""
    def __enter__(self):
        try:
            self.path = scratch.make(SCRATCH_PREFIX)
        except OSError:     # no temporary folder to write in: the run unpacks where it can, as it did before
            self.path = None
            return self
        self.previous, archive.UNPACK_DIR = archive.UNPACK_DIR, self.path
        return self

    def __exit__(self, *exc):
        if self.path is not None:
            archive.UNPACK_DIR = self.previous
            shutil.rmtree(self.path, ignore_errors=True)
            _sweep_left_scratch()
        return False


_sweep_left = scratch.sweep_left      # the sweep a campaign's workers share (master/scratch.py)


def _prepare_while_the_child_starts(sink_names) -> None:
    """Imports what the sinks need when they open (the Parquet writer: pyarrow.parquet with pyarrow.fs, ~20-60 ms)
    and when they write side by side (a thread pool), and loads the CSV sink's C formatter (~2 ms with its tables),
    while the child starts, so that a short run does not wait for these at its end (on two cores the two overlap;
    the child's shared block is made as soon as it asks). What no step waits for is left to the supervisor's idle
    moments (``IDLE_CHORES``)."""
    import concurrent.futures.thread  # noqa: F401 - the pool's module, imported when the pool is first made
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:     # the sink that needs it says so when it opens
        pass
    if "csv" in sink_names:
        from .sinks.csv_native import formatter
        formatter()         # else built or loaded at the first block


#: what the supervisor does when it would otherwise wait for its child (``_Supervisor.run``), one at a time, and
#: whatever is left once the child is gone: run.json's platform name (``uname -p`` in a subprocess, 2-17 ms), and the
#: sweeps of the shared blocks and scratch folders that killed runs left (a listing of the temporary folder, ~3 ms
#: with the ~7,000 entries of a shared machine's). On a short run the supervisor's start (pyarrow and its Parquet
#: writer, ~45 ms) is the longer of the two processes', and these came first in it; now they fill its waits (for
#: the child's columns, its account, its exit), or, with none, its end.
IDLE_CHORES = (platform_name, _sweep_left_blocks, _sweep_left_scratch)


class _Supervisor:
    def __init__(self, scenario, options: Options, timeout: float | None):
        self.scenario, self.options, self.timeout = scenario, options, timeout
        self.out_dir = Path(options.output)
        self.sink_names = options.sinks or (["parquet"] + (["csv"] if options.write_csv else []))
        for name in self.sink_names:        # an unknown sink is the caller's error before any process starts
            if name not in BUILTIN_SINKS:
                SINKS.get(name, element="sinks")
        self.group: SinkGroup | None = None         # made once the child has started (_open_sinks)
        self.schema = None
        self.mm = None
        self.header = None
        self.block = None
        self.pending_str: list = []
        self.blocks_received = 0
        self.events: list = []
        self.meta: dict | None = None
        self.announced_exit: int | None = None     # the status the child said it exits with, after its meta
        self.names: list[str] = []
        self.step_lines: dict = {}
        self.stop_reason: str | None = None        # why this process ended the child
        self.kill_at: float | None = None
        self.forward_at: float | None = None        # when to pass an interrupt on to the child
        self.forward_signal = signal.SIGINT
        self.write_error: CosimError | None = None
        self.native_loop = False                    # the child steps in the native loop
        self.finishing = False                      # the child's simulation has ended: it writes its products
        self.hard_stop = False                      # a kill that no finishing phase postpones
        self.interrupts = 0

    # messages ---------------------------------------------------------------------------------------------
    def handle(self, msg, conn):
        kind = msg[0]
        if kind == "block":
            # the rows are copied out of the shared block (block_table's one transposing copy) before the child is
            # told it may fill the block again; the sinks then write the copy while the child goes on
            rows = self.block[:msg[1]]
            try:
                table = block_table(self.schema, rows, self.pending_str[:len(rows)])
            finally:        # the child waits for this word, also when the table could not be built
                try:
                    conn.send(("taken",))
                except OSError:         # the child has died: the block is still written
                    pass
            self.blocks_received += 1
            self.pending_str = []
            if self.write_error is None:
                try:
                    self.group.write(table)
                except CosimError as exc:     # a full disk: stop the child, keep what is written
                    self.write_error = exc
                    self.stop("results could not be written", kill=True)
        elif kind == "str":
            self.pending_str.append(msg[1])
        elif kind == "event":
            self.events.append(msg[1])
        elif kind == "schema":
            self.schema = schema_of(msg[1])
            rows, cols, path = msg[2], msg[3], msg[4]
            try:
                fd = os.open(path, os.O_RDWR)
                try:
                    self.mm = mmap.mmap(fd, 0)
                finally:
                    os.close(fd)
            except OSError as exc:          # not expected: the child made it; the run cannot be kept
                self.write_error = CosimError(f"cannot map the shared block {path}: {exc}", element="results")
                self.stop("results could not be written", kill=True)
                return
            finally:
                try:
                    os.unlink(path)         # both processes have it mapped: nothing is left behind whatever happens
                except FileNotFoundError:
                    pass
            self.header = np.ndarray((HEADER,), dtype=np.float64, buffer=self.mm)
            self.block = np.ndarray((rows, cols), dtype=np.float64, buffer=self.mm, offset=HEADER * 8)
            try:
                self.group.open(self.schema)
            except CosimError as exc:       # a disk full before the first row: the child is stopped, no row kept
                self.write_error = exc
                self.stop("results could not be written", kill=True)
        elif kind == "close":
            self.finishing_started()
            self.group.close()
            if msg[1]:          # the child waits for the files before its monitors read them
                conn.send(("closed", {"rows": self.group.rows, **({"notes": self.group.notes} if self.group.notes
                                                                      else {})}))
        elif kind == "names":
            self.names, self.step_lines = msg[1], msg[2]
        elif kind == "native_loop":
            self.native_loop = True
        elif kind == "meta":
            self.meta, self.events, self.announced_exit = msg[1], list(msg[2]), msg[3]

    def stop(self, reason: str, kill: bool = False):
        if self.stop_reason is None:
            self.stop_reason = reason
        if kill:
            self.kill_at = time.monotonic()
            self.hard_stop = True
        elif self.kill_at is None:
            self.kill_at = time.monotonic() + (FINISH_S if self.finishing else GRACE_S)

    def finishing_started(self):
        """The child has ended its simulation and writes its products (the monitors' summaries, maps, CSVs),
        which an unsupervised run takes seconds to write: an interrupt asked for no more than that, so the
        grace of a child that did not answer no longer applies (a second interrupt, a timeout still kill)."""
        self.finishing = True
        if self.kill_at is not None and not self.hard_stop:
            self.kill_at = max(self.kill_at, time.monotonic() + FINISH_S)

    # the run --------------------------------------------------------------------------------------------
    def run(self, settle=None) -> dict:
        """The run, to the child's end; ``settle(meta)`` (run_supervised's) completes run.json and the output folder
        and says whether the folder went back to the earlier run. A child that has announced how it exits (its
        last message) is settled while the kernel tears its process down, and run.json is corrected if it then
        exits otherwise (a crash in its teardown, a kill): the tail of a short run is the teardown of the two
        processes, which then overlap."""
        settle = settle or (lambda meta: False)
        parent, child = _channel_pair()
        options = self.options.as_dict()
        unpack_dir = scratch.make(SCRATCH_PREFIX)
        proc = _ForkedChild(_child, (child, parent, os.getpid(), self.scenario, options, unpack_dir))
        previous = {}

        def on_signal(signum, frame):
            name = "interrupted by the user" if signum == signal.SIGINT else f"stopped by {SIGNAL_NAMES[signum]}"
            self.interrupts += 1
            self.stop(name, kill=self.finishing and self.interrupts > 1)      # the second one still kills
            # a Ctrl-C in a terminal reaches the child too: pass it on only if the child has not ended soon after
            # (a second interrupt could cut the child's own orderly close short); SIGTERM at once
            if self.forward_at is None:
                self.forward_at = time.monotonic() + (0.5 if signum == signal.SIGINT else 0.0)
                self.forward_signal = signum
        for s in (signal.SIGINT, signal.SIGTERM):
            previous[s] = signal.signal(s, on_signal)
        t0 = time.monotonic()
        killed = False
        meta = None
        chores = list(IDLE_CHORES)
        try:
            proc.start()
            child.close()
            # only in a process of the command's own (an API caller's objects are not frozen): the ~15 collections
            # pyarrow's import set off took ~3 ms of this process's start, which on a short run is the longer one
            with _loaded_frozen(active=OWN_PROCESS and gc.isenabled()):
                self._open_sinks(proc)
                _prepare_while_the_child_starts(self.sink_names)
            open_conn = True
            while True:
                if not open_conn and meta is None and self.announced_exit is not None and not killed:
                    meta = self._finish(self.announced_exit, killed)
                    restored = settle(meta)
                waited_for = [parent, proc.sentinel] if open_conn else [proc.sentinel]
                if chores and not _ready(waited_for, 0.0):
                    chores.pop(0)()         # nothing to handle: a chore, then the messages and checks again
                    continue
                ready = _ready(waited_for, timeout=0.2)
                if open_conn and parent in ready:
                    # a bounded turn: a child streaming rows keeps the pipe full, and the stop checks below must
                    # still run (a timeout, an interrupt to pass on, a kill that is due)
                    turn_end = time.monotonic() + TURN_S
                    try:
                        self.handle(parent.recv(), parent)
                        while time.monotonic() < turn_end and parent.poll():
                            self.handle(parent.recv(), parent)
                    except EOFError:
                        open_conn = False
                    except Exception:   # noqa: BLE001 - a message cut short by the child's death
                        open_conn = False
                elif proc.sentinel in ready:
                    break
                now = time.monotonic()
                if self.forward_at is not None and now >= self.forward_at:
                    self.forward_at = float("inf")
                    try:
                        os.kill(proc.pid, self.forward_signal)
                    except ProcessLookupError:
                        pass
                if self.timeout is not None and now - t0 > self.timeout and self.stop_reason is None:
                    self.stop(f"timed out after {self.timeout:g} s", kill=True)
                if self.kill_at is not None and now >= self.kill_at and not killed:
                    killed = True
                    self._dump_stack(proc)
                    proc.kill()
            proc.join()
            while open_conn and parent.poll():
                try:
                    self.handle(parent.recv(), parent)
                except Exception:   # noqa: BLE001 - a message cut short by the child's death
                    break
        finally:
            if meta is not None and proc.exitcode is None:     # settled, then stopped by an error: still reaped
                proc.join()
            for s, h in previous.items():
                signal.signal(s, h)
            parent.close()
            if proc.exitcode is not None or proc.pid is None:      # the child is gone (or never started)
                shutil.rmtree(unpack_dir, ignore_errors=True)
        if meta is None:
            meta = self._finish(proc.exitcode, killed)
            settle(meta)
        elif proc.exitcode != self.announced_exit:
            meta["supervised"]["child_exit"] = proc.exitcode
            if not restored:        # (else the folder holds the earlier run again, with its own run.json)
                _write_run_files(self.out_dir, meta, self.events)
        for chore in chores:        # no idle moment came for these
            chore()
        return meta

    def _open_sinks(self, proc):
        """The sinks, made while the child starts: importing them imports pyarrow (~30-40 ms), which the child
        does not need (it names its columns as plain data, ``_ChildRecording._new_block``)."""
        try:
            self.group = SinkGroup([SINKS.get(n, element="sinks")() for n in self.sink_names], self.out_dir)
        except BaseException:       # a sink that cannot be made: no run, as when it was made before the child
            proc.kill()
            proc.join()
            (self.out_dir / CRASH_FILE).unlink(missing_ok=True)
            raise

    def _dump_stack(self, proc):
        """SIGUSR1 makes the child's faulthandler write where it is, even inside a C call that never returns."""
        try:
            os.kill(proc.pid, signal.SIGUSR1)
            time.sleep(0.2)
        except ProcessLookupError:
            pass

    def _culprit(self) -> tuple[str | None, str]:
        """(component, phase) whose FMI call the child was in, from its stack dump or the shared probe."""
        stack = self.out_dir / CRASH_FILE
        text = stack.read_text(errors="replace") if stack.is_file() else ""
        for m in reversed(list(re.finditer(r'File "<cosim-master step[^"]*>", line (\d+)', text))):
            i = self.step_lines.get(int(m.group(1)))
            if i is not None and i < len(self.names):
                return self.names[i], PHASE_NAMES[PHASE_STEP]
        if self.header is not None and self.names:
            phase, i = int(self.header[H_PHASE]), int(self.header[H_COMPONENT])
            if phase == PHASE_STEP:         # the native loop says which component's call a step is in, or the
                i = int(self.header[H_NATIVE])      # reference step (Runtime.calling), or nobody
                if i < 0:
                    i = int(self.header[H_COMPONENT])
            if 0 <= i < len(self.names):
                return self.names[i], PHASE_NAMES.get(phase, "setup")
        return None, ""

    def _last_fmu_error(self, component: str) -> str | None:
        """The component's last error message in fmu.log (it often says why it crashed)."""
        log = self.out_dir / "fmu.log"
        if not log.is_file():
            return None
        found = None
        for line in log.read_text(errors="replace").splitlines():
            if line.startswith(f"[error] {component}:") or line.startswith(f"[error] {component}/"):
                found = line.split(": ", 1)[1] if ": " in line else line
        return found

    def _recover_rows(self) -> int:
        """The rows of the block the child was filling (not sent): from shared memory."""
        if self.header is None or self.write_error is not None:
            return 0
        if self.blocks_received > int(self.header[H_BLOCKS]):
            return 0       # the child died between sending a block and saying so: those rows are written
        n = int(self.header[H_FILL])
        if n <= 0:
            return 0
        import pyarrow as pa
        str_rows = self.pending_str[:n]
        if len(str_rows) < n and any(f.type in (pa.string(), pa.binary()) for f in self.schema):
            n = len(str_rows)      # a row whose strings never arrived is incomplete
        if n == 0:
            return 0
        try:
            self.group.write(block_table(self.schema, self.block[:n].copy(), str_rows))
        except CosimError as exc:
            self.write_error = exc
            return 0
        return n

    def _finish(self, exitcode: int | None, killed: bool) -> dict:
        recovered = 0 if self.meta is not None else self._recover_rows()
        last = self.header_time
        # a full disk is nobody's fault: the component running when the child was stopped for it is not named
        culprit, phase = self._culprit() if self.meta is None and self.write_error is None else (None, "")
        try:
            self.group.close()
        finally:
            if self.mm is not None:
                self.header = self.block = None
                self.mm.close()
        meta = self.meta or {"scenario": str(self.scenario), "outcome": "error"}
        if meta.get("platform", "") is None:        # the child left it to this process (execution.platform_name)
            meta["platform"] = platform_name()
        meta["rows_recorded"] = self.group.rows
        if self.group.notes:
            meta["results_notes"] = self.group.notes
        meta["supervised"] = {"child_exit": exitcode, **({"rows_recovered": recovered} if recovered else {})}
        if self.meta is None:
            if self.native_loop:
                meta["native_loop"] = {"used": True}
            during = f" during {phase}" if phase else ""
            if self.write_error is not None:
                reason = str(self.write_error)
                meta["outcome"] = "error"
            elif exitcode is not None and exitcode < 0 and not killed:
                reason = f"the simulation process was killed by signal {SIGNAL_NAMES.get(-exitcode, -exitcode)}{during}"
                meta["outcome"] = "crashed"
            elif self.stop_reason is not None:
                reason = self.stop_reason
                if killed and self.finishing and culprit is None:
                    reason += (" (the simulation had ended; it was killed while writing the run's products, "
                               "which may be incomplete)")
                elif killed and "timed out" not in reason:
                    reason += f" (the simulation did not stop within {GRACE_S:g} s and was killed{during})"
                elif killed:
                    reason += f"{during} (the simulation was killed)"
                interrupted = "user" in reason or "stopped by" in reason
                meta["outcome"] = "interrupted" if interrupted else "error"
            else:
                reason = f"the simulation process ended with exit status {exitcode} without reporting"
            detail = self._last_fmu_error(culprit) if culprit and meta["outcome"] == "crashed" else None
            if detail:
                reason += f": {detail}"
            err = CosimError(reason, element=f"component {culprit}" if culprit else None,
                             time=float(last) if last is not None else None)
            meta["error"] = str(err)
            meta["last_time"] = err.time
            if culprit:
                meta["failed_component"] = culprit
        elif self.write_error is not None:
            meta["outcome"], meta["error"] = "error", str(self.write_error)
        meta.setdefault("wall_time_s", None)
        (self.out_dir / CRASH_FILE).unlink(missing_ok=True)
        if self.out_dir.is_dir():
            _write_run_files(self.out_dir, meta, self.events)
        return meta

    @property
    def header_time(self):
        if self.header is None:
            return None
        return self.header[H_TIME] if self.header[H_TIME] else self.header[H_LAST_ROW]


def _write_run_files(out_dir: Path, meta: dict, events: list) -> None:
    """run.json and events.csv; on a full disk the run is failed with one line saying so, not a traceback."""
    try:
        write_run_files(out_dir, meta, events)
    except OSError as exc:
        meta["outcome"] = "error"
        meta.setdefault("error", write_failure(exc, exc.filename or str(out_dir / "run.json")))


def run_supervised(scenario, *, timeout: float | None = None, **options):
    """``run`` with the simulation in a child process (see the module docstring); needs an output folder."""
    from .runner import Result
    opts = Options(**options)
    from .live import check_options
    check_options(opts)
    if opts.output is None:
        raise CosimError("a supervised run needs an output folder", element="--output")
    out_dir = Path(opts.output)
    claim_output_folder(out_dir)
    try:
        t0 = time.perf_counter()
        sup = _Supervisor(scenario, opts, timeout)

        def settle(meta: dict) -> bool:
            if meta.get("wall_time_s") is None:
                meta["wall_time_s"] = time.perf_counter() - t0
                _write_run_files(out_dir, meta, sup.events)
            # the earlier run in the folder goes now that this one has rows, or comes back if it has none
            return settle_output_folder(out_dir, bool(meta.get("rows_recorded")))
        meta = sup.run(settle)
    finally:
        release_output_folder(out_dir)
    result = Result(out_dir, meta, sup.events)
    if meta.get("outcome") != "completed":
        err = CosimError(meta.get("error") or f"run ended with outcome {meta.get('outcome')}")
        err.result = result
        raise err
    return result
