"""The sinks of a run written as one: every block reaches all of them or none, a Ctrl-C never lands in the
middle of a write, and a failing write (a full disk) ends the run with the outputs still readable and equal.

How: SIGINT is deferred while a block is written (delivered right after); before each block every sink marks
where it stands, and when one fails the others roll back to their mark (CSV truncates). The sinks that can take
rows still (the CSV) are then given the block's rows again in ever smaller slices until one more row does not
fit, so that every row that fitted is kept, not only the blocks before; the space reserved at the start is given
back, and a Parquet file that could not be completed is rebuilt from the CSV at close.
"""
from __future__ import annotations

import contextlib
import errno
import os
import signal
import threading
from pathlib import Path

from ..errors import CosimError

RESERVE_NAME = ".cosim-master.reserve"
RESERVE_BYTES = 4 << 20     # room for truncation, a Parquet footer, run.json and events.csv on a full disk

#: what a failed write means for the person who reads the message: the disk, not a component or the master
NO_ROOM = {errno.ENOSPC: "disk full", errno.EFBIG: "file size limit reached", errno.EDQUOT: "disk quota exceeded"}


def write_failure(exc: OSError, where: str) -> str:
    """One line for a write into ``where`` that failed."""
    why = NO_ROOM.get(exc.errno)
    return f"{why} while writing {where}" if why else f"cannot write {where}: {exc.strerror or exc}"


@contextlib.contextmanager
def deferred_interrupt():
    """SIGINT held back until the block is written (main thread only; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    except (ValueError, TypeError):      # no signals here (embedded interpreter)
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught:
            signal.raise_signal(signal.SIGINT)


class SinkGroup:
    def __init__(self, sinks: list, out_dir: Path | None):
        self.sinks = sinks
        self.out_dir = out_dir
        self.rows = 0
        self.failure: str | None = None
        self.notes: list[str] = []
        self._reserve = None
        self.open_sinks: list = []
        self._closed = False
        self._threads = None

    def open(self, schema) -> None:
        self.schema = schema
        self._closed = False
        wanted = [s for s in self.sinks if self.out_dir is not None or not s.needs_folder]
        # the reserve is given back before anything but the sinks writes into the folder: without a sink writing
        # there (a campaign run's rows kept in memory) it would only cost creating and removing a 4 MB file
        if self.out_dir is not None and any(s.needs_folder for s in wanted):
            self._reserve = self.out_dir / RESERVE_NAME
            try:
                with open(self._reserve, "wb") as fh:
                    fh.truncate(RESERVE_BYTES)
                    os.posix_fallocate(fh.fileno(), 0, RESERVE_BYTES)
            except (OSError, AttributeError):
                self._release_reserve()     # no room even for the reserve: the first block will tell
        failed = self._open_each(wanted, schema)
        if failed is not None and self._reserve is not None and failed[1].errno in NO_ROOM:
            # the reserve took the room that the files' first bytes need (a disk with a little more than
            # RESERVE_BYTES free): without it, as when it cannot be had at all, the first block will tell
            self._release_reserve()
            failed = self._open_each(wanted, schema)
        if failed is not None:      # a disk full before the first row: no result file, one line
            s, exc = failed
            self._release_reserve()
            where = exc.filename or ", ".join(str(f) for f in s.files()) or str(self.out_dir)
            self.failure = write_failure(exc, where)
            raise CosimError(self.failure, element="results") from None

    def _open_each(self, sinks: list, schema):
        """Opens every sink of ``sinks`` (then ``open_sinks``); returns None, or (the sink whose open failed, its
        OSError) with every sink tried closed, its files removed and ``open_sinks`` empty."""
        self.open_sinks = sinks
        for k, s in enumerate(sinks):
            try:
                s.open(self.out_dir, schema)
            except OSError as exc:
                self.open_sinks = []
                for t in sinks[:k + 1]:
                    with contextlib.suppress(Exception):
                        t.close()
                    for f in t.files():
                        with contextlib.suppress(OSError):
                            f.unlink()
                return s, exc
        return None

    @property
    def defers(self) -> bool:
        """True when every open sink takes a block whose table is built on demand
        (``master.observers.recording.DeferredBlock``): none of them writes it out."""
        return bool(self.open_sinks) and all(getattr(s, "takes_deferred", False) for s in self.open_sinks)

    def write(self, table) -> None:
        if self.failure is not None:
            return
        with deferred_interrupt():
            marks = [s.mark() for s in self.open_sinks]
            failed = self._write_each(table)
            if failed is not None:
                s, exc = failed
                for other, m in zip(self.open_sinks, marks):
                    other.rollback(m)
                # the reserve is still held: the rows kept here leave room for closing the files
                self.rows += self._rows_that_fit(table)
                self._release_reserve()
                where = ", ".join(str(p) for p in s.files()) or type(s).__name__
                self.failure = write_failure(exc, where)
                raise CosimError(self.failure, element="results") from None
            self.rows += table.num_rows

    def _write_each(self, table):
        """Every open sink writes ``table``; returns (the first sink that failed, its OSError) or None. The sinks
        that let go of the GIL while they write (``concurrent``: Parquet, the CSV formatted in C) write at the
        same time, the first here and the others on a helper thread each, and all have finished on return; a
        block is still written everywhere or rolled back everywhere."""
        side = [s for s in self.open_sinks if getattr(s, "concurrent", False)][1:]
        futures = {s: self._pool(len(side)).submit(_written, s, table) for s in side} if side else {}
        errors = {}
        try:
            for s in self.open_sinks:
                if s not in futures:
                    errors[s] = _written(s, table)
        finally:       # the helpers have finished before anything else happens, an interrupt here included
            for s, f in futures.items():
                errors[s] = f.result()
        for s in self.open_sinks:       # the first in the sinks' order, as if written one after another
            if errors[s] is not None:
                if not isinstance(errors[s], OSError):
                    raise errors[s]
                return s, errors[s]
        return None

    def _pool(self, workers: int):
        if self._threads is None:
            from concurrent.futures import ThreadPoolExecutor
            self._threads = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="sink")
        return self._threads

    def _rows_that_fit(self, table) -> int:
        """Writes the longest first part of ``table`` that the sinks still able to take rows accept (every one
        the same rows); returns its rows. Halving the slice after each failure finds it in a few writes."""
        live = [s for s in self.open_sinks if not s.broken]
        if not any(s.needs_folder for s in live):       # no file left to hold the rows
            return 0
        kept, size = 0, table.num_rows
        while size >= 1 and kept < table.num_rows:
            part = table.slice(kept, size)
            marks = [s.mark() for s in live]
            try:
                for s in live:
                    s.write(part)
            except OSError:
                for s, m in zip(live, marks):
                    s.rollback(m)
                if any(s.broken for s in live):         # one that cannot undo: stop at the rows before
                    break
                size //= 2
                continue
            kept += part.num_rows
        return kept

    def close(self) -> None:
        if getattr(self, "_closed", False):
            return
        self._closed = True
        if getattr(self, "_threads", None) is not None:
            self._threads.shutdown()
            self._threads = None
        with deferred_interrupt():
            for s in self.open_sinks:
                try:
                    s.close()
                except OSError as exc:
                    self._release_reserve()
                    s.broken = True
                    self.notes.append(f"closing {', '.join(str(p) for p in s.files())}: {exc.strerror or exc}")
            for s in self.open_sinks:
                if getattr(s, "broken", False):
                    try:
                        self.notes.append(s.repair(self.open_sinks, self.schema, self.rows))
                    except OSError as exc:
                        where = ", ".join(str(p) for p in s.files())
                        self.notes.append(f"{write_failure(exc, where)}: not rebuilt, the rows are in the other "
                                          "result files")
            self._release_reserve()

    def files(self) -> list[Path]:
        return [p for s in self.open_sinks for p in s.files()]

    def _release_reserve(self):
        if self._reserve is not None:
            with contextlib.suppress(OSError):
                self._reserve.unlink()
            self._reserve = None


def _written(sink, table):
    """None when ``sink`` wrote ``table``, else the exception its write raised."""
    try:
        sink.write(table)
    except Exception as exc:        # noqa: BLE001 -- handed to the group, which rolls back or raises it
        return exc
    return None
