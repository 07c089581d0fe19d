"""The monitor interface and the context the master hands to monitors."""
from __future__ import annotations

from pathlib import Path


class MonitorContext:
    """What a monitor may see and do: read observed values, record events, take components out."""

    def __init__(self, rt, events: list):
        self.rt = rt
        self.events = events

    def position(self, qualified: str) -> tuple[str, int]:
        v = self.rt.plan.var(qualified)
        return v.type, self.rt.out_pos[qualified]

    def buffer(self, typ: str):
        return self.rt.out[typ]

    def deactivate(self, components: list[str]) -> None:
        """The components stop stepping; their outputs keep their last values."""
        for name in components:
            self.rt.deactivate(self.rt.index[name])

    def emit(self, event: dict) -> None:
        self.events.append(event)

    def request_stop(self, reason: str) -> None:
        """End the run after this step (e.g. every vehicle has landed): the outcome stays 'completed' and
        run.json records when and why the run ended before its stop time."""
        if self.rt.stop_reason is None:
            self.rt.stop_reason = reason


class Monitor:
    annotation_type = ""
    products = "all"      # "summary": a campaign wants the summary files only (set by run(products=...))

    def __init__(self, element, plan, shown_as: str):
        self.element = element
        self.plan = plan
        self.shown_as = shown_as

    def required_variables(self) -> list[str]:
        return []

    def attach(self, ctx: MonitorContext, start: float) -> None:
        self.ctx = ctx

    def after_step(self, n: int, t0: float, t1: float) -> None:
        pass

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        return {}
