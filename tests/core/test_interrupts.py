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
