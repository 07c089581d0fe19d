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
        set_between_steps(self.rt, self.rt.plan.var(qualified), value, element="manipulator")

    def request_stop(self, reason: str) -> None:
        """End the run after this step (e.g. every vehicle has landed): the outcome stays 'completed' and
        run.json records when and why the run ended before its stop time."""
        if self.rt.stop_reason is None:
            self.rt.stop_reason = reason


def set_between_steps(rt, v, value, element: str) -> None:
    """Give the variable ``v`` (a plan.Var) of an initialized system ``value`` between two steps, as FMI allows
    it there: an input that no connection drives (a connected one is overwritten by the next step's transfer)
    or a tunable parameter. One line naming ``element`` and the reason otherwise. A whole array takes a
    sequence; an array element is written by writing its array with that element changed."""
    from ..errors import CosimError
    from ..fmi.slave import WARNING
    from ..plan import parse_value
    qualified = v.qualified
    # a connection drives an array element by element: a whole array is driven when any element is
    driven = {e.qualified for e in rt.plan.elements(v)} if v.is_array else {qualified}
    if any(ln.dst.qualified in driven for ln in rt.plan.links):
        raise CosimError(f"{qualified} is driven by a connection; its value cannot be set between steps",
                         element=element)
    if not (v.causality == "input" or (v.causality == "parameter" and v.variability == "tunable")):
        raise CosimError(f"{qualified} is not an input or a tunable parameter (causality {v.causality}, "
                         f"variability {v.variability})", element=element)
    slave = rt.slaves[rt.index[v.component]]
    parsed = parse_value(v, value, qualified)
    if v.index is not None:          # FMI 3 sets an array as a whole: the others keep the values they have
        from ..fmi.slave import new_buffer
        elements = rt.plan.elements(v)
        buf = new_buffer(v.type, len(elements))
        st = slave.get_port(v.type, slave.make_port(v.type, [e.vr for e in elements], buf))
        if st > WARNING:
            raise slave.fail(f"getting {v.array}", st)
        values = buf.tolist()
        values[v.index] = parsed
        target, parsed = rt.plan.variables[v.component][v.array], values
    else:
        target = v
    st = slave.set_value(target.type, target.vr, parsed)
    if st > WARNING:
        raise slave.fail(f"setting {v.name}={value!r}", st)


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
