"""CPU time spent in chosen methods while a benchmark runs (bench_campaign.py --phases, bench_run_start.py,
bench_structure_reuse.py): each method is wrapped in place, its time added under a label, and put back by
``restore``."""
from __future__ import annotations

import time
from collections import defaultdict


class PhaseTimer:
    def __init__(self, clock=time.process_time):
        self.clock = clock
        self.spent: dict = defaultdict(float)
        self._originals: list = []

    def wrap(self, owner, name: str, label: str) -> None:
        fn = getattr(owner, name)
        clock, spent = self.clock, self.spent

        def wrapper(*a, **k):
            t0 = clock()
            try:
                return fn(*a, **k)
            finally:
                spent[label] += clock() - t0
        self._originals.append((owner, name, fn))
        setattr(owner, name, wrapper)

    def wrap_initialize(self, execution_cls, label: str) -> None:
        """``Execution.initialize`` without the ``setup`` it runs first when not set up (timed as setup)."""
        init = execution_cls.initialize
        clock, spent = self.clock, self.spent

        def initialize(execution):
            if not execution._set_up:
                execution.setup()
            t0 = clock()
            try:
                return init(execution)
            finally:
                spent[label] += clock() - t0
        self._originals.append((execution_cls, "initialize", init))
        execution_cls.initialize = initialize

    def restore(self) -> None:
        for owner, name, fn in reversed(self._originals):
            setattr(owner, name, fn)
        self._originals.clear()
