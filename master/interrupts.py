"""Ctrl-C and SIGTERM held back while a run closes.

Closing a run writes its last block, terminates the FMUs and writes run.json. An interrupt in the middle left
results without their run.json, or a run.json that said "completed" beside a process that exited as failed.
Inside ``deferred()`` the signals are only noted; when the block ends each is delivered to the handler that
was in place before, so the interrupt still takes effect, just after the files are whole.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def deferred():
    if threading.current_thread() is not threading.main_thread():     # only the main thread may set handlers
        yield
        return
    pending: list[int] = []
    previous = {s: signal.signal(s, lambda signum, frame: pending.append(signum)) for s in HELD}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        for s in dict.fromkeys(pending):
            signal.raise_signal(s)
