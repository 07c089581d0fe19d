"""Pacing: the run held to the wall clock (``--realtime FACTOR``: FACTOR simulated seconds per wall second).

An observer placed after every other one: once a step's work is done it sleeps until the wall clock has
caught up with the simulated time.  It only waits, so a paced run computes exactly what an unpaced one does.
A run slower than the pace is never hurried; how far behind it fell is in run.json.
"""
from __future__ import annotations

import time

from .base import Observer


class Pacer(Observer):
    name = "pacing"

    def __init__(self, factor: float, clock=time.monotonic, sleep=time.sleep):
        self.factor = float(factor)
        self.clock, self.sleep = clock, sleep
        self.late_steps = 0
        self.max_lag = 0.0

    def attach(self, ctx, start: float) -> None:
        super().attach(ctx, start)
        self.start = start
        self.wall0 = self.clock()

    def after_step(self, n: int, t0: float, t1: float) -> None:
        ahead = self.wall0 + (t1 - self.start) / self.factor - self.clock()
        if ahead > 0:
            self.sleep(ahead)
        elif ahead < 0:
            self.late_steps += 1
            self.max_lag = max(self.max_lag, -ahead)

    def finish(self, out_dir, outcome) -> dict:
        return {"factor": self.factor, "steps_behind": self.late_steps, "max_lag_s": round(self.max_lag, 6)}
