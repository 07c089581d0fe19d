"""Manipulators change the system between steps (a fault injection, a command from a ground station).

Called by the execution before each master step, after the observers of the previous one. They act through
``ctx.set_value``, which writes a variable that no connection drives (an unconnected input or a tunable
parameter): a connected input is rewritten by its connection at every step, so setting it is refused.
"""
from __future__ import annotations


class Manipulator:
    name = ""

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx

    def before_step(self, n: int, t: float) -> None:
        pass
