"""Replaying the ground-station commands of a run (its events.csv rows of type ``command``): the same
inputs of the strategies at the same steps, hence the same run, without a ground station.

    master.run("scenario.ssp", manipulators=[CommandReplay("earlier/events.csv")])
"""
from __future__ import annotations

from pathlib import Path

from master.errors import CosimError
from master.manipulators import Manipulator
from uavsim.strategy import COMMAND_NONE

from ..names import STRATEGY, component
from .fleet import COMMAND_INPUT
from .stream import COMMANDS

CODES = {what: code for code, _state, what in COMMANDS.values()}


class CommandReplay(Manipulator):
    name = "mavlink-replay"

    def __init__(self, events_csv):
        import pandas as pd
        path = Path(events_csv)
        try:
            events = pd.read_csv(path)
        except (OSError, ValueError) as exc:
            raise CosimError(f"cannot read the events: {exc}", file=str(path)) from None
        self.schedule: dict[float, list[tuple[str, int]]] = {}
        if "type" not in events:
            return
        for row in events[events["type"] == "command"].itertuples():
            if row.event not in CODES:
                raise CosimError(f"unknown command {row.event!r} at t={row.time}", file=str(path))
            self.schedule.setdefault(round(float(row.time), 9), []).append((row.uav, CODES[row.event]))
        self.to_reset: list[str] = []

    def before_step(self, n: int, t: float) -> None:
        for q in self.to_reset:
            self.ctx.set_value(q, COMMAND_NONE)
        self.to_reset = []
        for uav, code in self.schedule.get(round(t, 9), ()):
            q = f"{component(uav, STRATEGY)}.{COMMAND_INPUT}"
            self.ctx.set_value(q, code)
            self.to_reset.append(q)
