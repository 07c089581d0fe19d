"""Ctrl-C while a run closes is held until its files are whole, then delivered (master/interrupts.py)."""
from __future__ import annotations

import os
import signal

import pytest

from master import interrupts


def test_an_interrupt_inside_is_delivered_after_the_block():
    before = signal.getsignal(signal.SIGINT)
    if before is not signal.default_int_handler:
        pytest.skip("this process handles SIGINT itself")
    done = []
    with pytest.raises(KeyboardInterrupt):
        with interrupts.deferred():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("the rest of the block ran")
    assert done == ["the rest of the block ran"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler      # the handler is back


def test_without_an_interrupt_nothing_happens():
    before = signal.getsignal(signal.SIGINT)
    with interrupts.deferred():
        pass
    assert signal.getsignal(signal.SIGINT) is before


def _qsort_calling(compare):
    import ctypes
    libc = ctypes.CDLL("libc.so.6")
    cmp_type = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))
    values = (ctypes.c_int * 8)(5, 3, 7, 1, 8, 2, 6, 4)
    libc.qsort(values, len(values), ctypes.sizeof(ctypes.c_int), cmp_type(compare))
    return list(values)


def test_an_interrupt_inside_a_ctypes_callback_reaches_the_caller_after_the_foreign_call(monkeypatch):
    """libc's qsort stands in for an FMU calling the master's logger: the first comparison is where a pending
    Ctrl-C's handler runs. ctypes alone prints the KeyboardInterrupt and drops it, and qsort finishes."""
    import sys
    import time
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("this process handles SIGINT itself")
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)     # the hook is undone after the test
    monkeypatch.setattr(interrupts, "_hook_installed", False)
    interrupts.keep_interrupts_from_callbacks()
    calls = []

    def compare(a, b):
        calls.append(1)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)      # its handler runs inside this callback
        return a[0] - b[0]
    with pytest.raises(KeyboardInterrupt) as caught:
        _qsort_calling(compare)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            time.sleep(0.01)
    assert len(calls) > 1                   # qsort went on: ctypes had dropped the interrupt in the callback
    assert "compare" not in [entry.name for entry in caught.traceback]     # raised again outside it


def test_other_exceptions_in_callbacks_still_go_to_the_previous_hook(monkeypatch):
    import sys
    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.exc_type))
    monkeypatch.setattr(interrupts, "_hook_installed", False)
    interrupts.keep_interrupts_from_callbacks()
    interrupts.keep_interrupts_from_callbacks()          # idempotent: one hook, not two

    def compare(a, b):
        raise ValueError("a bug in a callback")
    _qsort_calling(compare)
    assert seen and set(seen) == {ValueError}
    assert sys.unraisablehook.previous.__name__ == "<lambda>"
