"""The observer interface and the context the execution hands to observers."""
from __future__ import annotations

from pathlib import Path


class ObserverContext:
    """What an observer may see and do: read the master's value buffers, record events, take components out,
    end the run early."""

    def __init__(self, rt, events: list):
        self.rt = rt
        self.events = events

    def position(self, qualified: str) -> tuple[str, int]:
        """(base type, index in ``buffer(type)``) of a variable listed in ``required_variables``."""
        v = self.rt.plan.var(qualified)
        return v.type, self.rt.out_pos[qualified]

    def buffer(self, typ: str):
        return self.rt.out[typ]

    def deactivate(self, components: list[str]) -> None:
        """The components stop stepping; their outputs keep their last values."""
        for name in components:
            self.rt.deactivate(self.rt.index[name])

    def emit(self, event: dict) -> None:
        """An event row for events.csv (keys become columns)."""
        self.events.append(event)

    def set_value(self, qualified: str, value) -> None:
        """Write a variable that no connection drives (an unconnected input, a tunable parameter) now; it
        takes effect in the next step (manipulators)."""
        from ..errors import CosimError
        from ..fmi.slave import WARNING
        from ..plan import parse_value
        rt = self.rt
        v = rt.plan.var(qualified)
        if any(ln.dst.qualified == qualified for ln in rt.plan.links):
            raise CosimError(f"{qualified} is driven by a connection; its value cannot be set between steps",
                             element="manipulator")
        if not (v.causality == "input" or (v.causality == "parameter" and v.variability == "tunable")):
            raise CosimError(f"{qualified} is not an input or a tunable parameter (causality {v.causality}, "
                             f"variability {v.variability})", element="manipulator")
        slave = rt.slaves[rt.index[v.component]]
        st = slave.set_value(v.type, v.vr, parse_value(v, value, qualified))
        if st > WARNING:
            raise slave.fail(f"setting {v.name}={value!r}", st)

    def request_stop(self, reason: str) -> None:
        """End the run after this step (e.g. every vehicle has landed): the outcome stays 'completed' and
        run.json records when and why the run ended before its stop time."""
        if self.rt.stop_reason is None:
            self.rt.stop_reason = reason


class Observer:
    name = ""

    def required_variables(self) -> list[str]:
        """Variables (``component.variable``) read after every step for this observer."""
        return []

    def sampled_variables(self) -> list[str]:
        """Variables this observer needs only when ``ctx.rt.read_samples`` is called (recording)."""
        return []

    def attach(self, ctx: ObserverContext, start: float) -> None:
        self.ctx = ctx

    def after_step(self, n: int, t0: float, t1: float) -> None:
        pass

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        """Called once at the end (also after a failure); returns facts for run.json."""
        return {}
