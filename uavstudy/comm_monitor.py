"""What strategy C's channel carried, into run.json and ``comm.json`` (docs/cooperative.md).

The channel FMU (fmu_sources/UavChannel.py) counts the messages itself -- sent, received, lost, out of range,
blocked by a zone, dropped beyond the k nearest -- and the near misses of the fleet; the strategies count their
takeovers, drops and give-ways.  This monitor, switched on by the annotation ``org.cosim-master.uav-comm`` that
``uavstudy.build`` writes for strategy C, reads those outputs once, when the run ends, and returns::

    {"channel": "channel", "messages": {"sent": 3520, "received": 9631, "lost": 1060, "out_of_range": 0, ...},
     "near_misses": 3, "uavs": {"uav1": {"sent": 880, "received": 2411, "lost": 262, "takeovers": 0, ...}, ...}}

which the engine stores under ``monitors["org.cosim-master.uav-comm"]`` in run.json; the same goes to
``comm.json`` in the run folder.  A counter is the FMU's own total, so its last value is the answer.

After every step it also looks at what C decided in it (one ``take`` of a few Integers per UAV, compared as bytes
first): C's **events** go to events.csv with the UAV monitor's columns, at the step's start time (the strategy
decided on its inputs then) and where the UAV was then (its strategy's position inputs), type ``coop``:

* ``takeover`` -- the UAV took over orphaned targets (detail: which, and whose claim they were: ``other``);
* ``drop`` -- it dropped targets to a better bid (``other``: the best bidder);
* ``give_way`` / ``give_way_end`` -- it started / stopped giving way to ``other`` (the right-of-way climb;
  ``distance``: horizontal, to the other's position then).

A detail's words before its first " (" say the event in short (the ground-station stream's status text, e.g.
"took over target 3 of uav2").

And it keeps **who heard whom**: the channel's message slots name the senders of the messages each UAV received
in a step; the links at a moment T are the (receiver, sender) pairs with a message arriving within one broadcast
period before T.  T is the annotation's ``linksAt`` when given, else the first takeover, else the first drop,
else the first give-way (none of them: no links).  They go to comm.json (``links``) and onto map.png
(uavstudy/outputs.py asks :func:`links_of` for the run's).
"""
from __future__ import annotations

import json
import math
import weakref
from collections import deque
from pathlib import Path

import numpy as np
from lxml import etree

from master.errors import ScenarioError
from master.monitors import Monitor, register
from master.ssp.writer import NS as SSP_NS
from uavsim.channel import MAX_K, ChannelParams, decode_mask

COMM_TYPE = "org.cosim-master.uav-comm"
COMM_NS = "https://cosim-master.org/ssp/uav-comm"
COMM_FILE = "comm.json"
FLEET = ("sent", "received", "lost", "out_of_range", "blocked", "overflow")
PER_UAV = ("sent", "received", "lost")
STRATEGY_COUNTS = ("takeovers", "drops", "give_ways")
#: C's outputs naming its last takeover, drop and give-way (uavsim/cooperative_fmi.py EVENT_OUTPUTS); with the
#: counts, what the monitor reads after every step
WATCHED = ("takeovers", "drops", "give_way_to", "taken0", "taken1", "taken_from", "dropped0", "dropped1",
           "dropped_to")
EVENT_TYPE = "coop"
#: which C event sets the moment of the links when the annotation names none, first choice first
LINK_MOMENTS = ("takeover", "drop", "give_way")
SLOTS = MAX_K                           # the channel's message slots per UAV
DEFAULT_PERIOD = ChannelParams.period   # s, its broadcast period when the SSD gives none

__all__ = ["CommMonitor", "comm_annotation", "links_of", "COMM_TYPE", "COMM_FILE", "EVENT_TYPE"]

#: the comm monitor of each running system, by its observer context: map.png (drawn by the UAV monitor) asks it
#: for the links. Weak both ways: the monitor holds its context, so a monitor kept as the value would keep its key
#: alive and every finished run (its buffers, plan and outputs) with it (a campaign worker grew by ~8 MB a run)
_BY_CONTEXT: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def links_of(ctx) -> dict | None:
    """The links the comm monitor of the run with this observer context kept (``CommMonitor.links``), None when
    the run has no comm monitor or no moment came."""
    ref = _BY_CONTEXT.get(ctx) if ctx is not None else None
    mon = ref() if ref is not None else None
    return mon.links() if mon is not None else None


def comm_annotation(channel: str, uavs: dict[str, str], links_at: float | None = None) -> etree._Element:
    """The ``ssc:Annotation`` switching the monitor on: the channel component and ``{uav name: strategy
    component}`` in channel port order (uav1, uav2, ...); ``links_at``, the moment of the links on the map (s;
    None: at the first C event)."""
    ann = etree.Element(f"{{{SSP_NS['ssc']}}}Annotation", nsmap={"ssc": SSP_NS["ssc"]}, type=COMM_TYPE)
    root = etree.SubElement(ann, f"{{{COMM_NS}}}Comm", nsmap={"comm": COMM_NS}, channel=channel)
    if links_at is not None:
        root.set("linksAt", repr(float(links_at)))
    for name, strategy in uavs.items():
        etree.SubElement(root, f"{{{COMM_NS}}}Uav", name=name, strategy=strategy)
    return ann


def _read(element, shown_as: str) -> tuple[str, dict[str, str], float | None]:
    channel, uavs, links_at = None, {}, None
    for el in element.iter():
        if not isinstance(el.tag, str):
            continue
        local = etree.QName(el).localname
        if local == "Comm":
            channel = el.get("channel")
            if el.get("linksAt") is not None:
                try:
                    links_at = float(el.get("linksAt"))
                except ValueError:
                    links_at = math.nan
                if not math.isfinite(links_at):
                    raise ScenarioError(f"linksAt must be a time in seconds, got {el.get('linksAt')!r}",
                                        file=shown_as, element="comm:Comm")
        elif local == "Uav":
            if not el.get("name") or not el.get("strategy"):
                raise ScenarioError("comm:Uav needs 'name' and 'strategy'", file=shown_as, element="comm:Comm")
            uavs[el.get("name")] = el.get("strategy")
    if not channel:
        raise ScenarioError(f"annotation {COMM_TYPE} names no channel component", file=shown_as,
                            element="comm:Comm")
    return channel, uavs, links_at


def _origin(plan, shown_as: str):
    """The UAV monitor's origin (its annotation in the same SSD), for the events' latitude and longitude; None
    without one."""
    from .monitor_config import parse_config
    from .names import MONITOR_TYPE
    element = getattr(getattr(plan, "model", None), "annotations", {}).get(MONITOR_TYPE)
    return None if element is None else parse_config(element, shown_as).origin


def _period(plan, channel: str) -> float:
    """The channel's broadcast period as the run set it (the last value given wins), else its default."""
    period = DEFAULT_PERIOD
    for var, value, _origin in getattr(plan, "params", ()):
        if var.component == channel and var.name == "period":
            period = float(value)
    return period


@register(COMM_TYPE)
class CommMonitor(Monitor):
    def __init__(self, element, plan, shown_as: str):
        super().__init__(element, plan, shown_as)
        self.channel, self.uavs, self.links_at = _read(element, shown_as)
        self.names = list(self.uavs)
        self.ctx = None
        self._last = None
        self.origin = _origin(plan, shown_as) if plan is not None else None
        self.period = _period(plan, self.channel) if plan is not None else DEFAULT_PERIOD
        self.moments: dict[str, dict] = {}       # why -> the links then (first takeover, drop, give-way; linksAt)
        # a strategy FMU built before C had its event outputs (an older SSP) still runs: counters and links, no events
        self.watched = WATCHED
        if plan is not None and self.uavs:
            try:
                plan.var(f"{next(iter(self.uavs.values()))}.{WATCHED[-1]}")
            except (KeyError, ValueError, TypeError, ScenarioError):
                self.watched = ()
        if plan is not None:
            for v in self.required_variables():
                try:
                    plan.var(v)
                except (KeyError, ValueError, TypeError, ScenarioError):
                    raise ScenarioError(f"{v} is not a variable of the system (not a UavChannel / UavStrategy?)",
                                        file=shown_as, element="comm:Comm") from None

    def required_variables(self) -> list[str]:
        c = self.channel
        names = [f"{c}.messages_{n}" for n in FLEET] + [f"{c}.near_misses"]
        for k, (name, strategy) in enumerate(self.uavs.items(), start=1):
            names += [f"{c}.uav{k}_{n}" for n in PER_UAV] + [f"{strategy}.{n}" for n in STRATEGY_COUNTS]
            names += [f"{strategy}.{n}" for n in self.watched if n not in STRATEGY_COUNTS]
            names += [f"{strategy}.{n}" for n in ("x", "y", "z")]
            names += [f"{c}.uav{k}_m{s}_sender" for s in range(1, SLOTS + 1)]
        return names

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx
        self._where = {v: ctx.position(v) for v in self.required_variables()}
        _BY_CONTEXT[ctx] = weakref.ref(self)
        n = len(self.names)
        strategies = list(self.uavs.values())
        # the watched values and the senders of the message slots are FMI Integers: ONE take per step reads them
        # all into one preallocated array (a numpy call per value would cost more than the rest of the step)
        watch = [self._where[f"{s}.{v}"] for s in strategies for v in self.watched]
        send = [self._where[f"{self.channel}.uav{k}_m{s}_sender"] for k in range(1, n + 1)
                for s in range(1, SLOTS + 1)]
        types = {typ for typ, _ in watch + send}
        if len(types) > 1:
            raise ScenarioError(f"the strategies' C outputs and the channel's senders have different types "
                                f"({', '.join(sorted(types))}): not a UavStrategy / UavChannel?", file=self.shown_as,
                                element="comm:Comm")
        self._type = types.pop() if types else "Integer"
        self._idx = np.array([j for _, j in watch + send], dtype=np.intp)
        self._read = np.empty(self._idx.size, dtype=ctx.buffer(self._type).dtype)
        self._nw = len(watch)
        self._gather()
        self._watch = self._read[:self._nw].astype(np.int64).reshape(n, len(self.watched))
        self._watch_bytes = self._read[:self._nw].tobytes()
        self._no_message = np.full(len(send), -1, dtype=self._read.dtype).tobytes()
        # (end of the step, the senders of every slot as bytes) of the last period's steps with arrivals
        self._recent: deque = deque()
        # with linksAt, who heard whom matters only in the period before it
        self._track_from = -math.inf if self.links_at is None else self.links_at - self.period - 1.0

    def _gather(self) -> None:
        self.ctx.buffer(self._type).take(self._idx, out=self._read, mode="clip")   # indices are valid

    def _value(self, name: str) -> int:
        typ, j = self._where[name]
        return int(self.ctx.buffer(typ)[j])

    def _real(self, name: str) -> float:
        typ, j = self._where[name]
        return float(self.ctx.buffer(typ)[j])

    def position(self, k: int) -> tuple[float, float, float]:
        """Where UAV k was at the start of the last step: its strategy's position inputs, what it decided on."""
        s = self.uavs[self.names[k]]
        return tuple(self._real(f"{s}.{a}") for a in ("x", "y", "z"))

    # -- after every step ----------------------------------------------------------------------------
    def after_step(self, n: int, t0: float, t1: float) -> None:
        self._gather()
        read = self._read
        if read[:self._nw].tobytes() != self._watch_bytes:
            watch = read[:self._nw].astype(np.int64).reshape(self._watch.shape)
            self._events(t0, self._watch, watch)
            self._watch, self._watch_bytes = watch, read[:self._nw].tobytes()
        if self.links_at is not None and "linksAt" not in self.moments and t0 >= self.links_at - 1e-9:
            self._moment("linksAt", t0)
        if t1 >= self._track_from and self._needs_senders():
            b = read[self._nw:].tobytes()
            if b != self._no_message:
                # kept as bytes, decoded only at the moment (a slot naming the same sender as in the last step is a
                # new message of it: every non-empty slot counts)
                recent = self._recent
                recent.append((t1, b))
                while recent[0][0] <= t1 - self.period - 1e-9:
                    recent.popleft()

    def _needs_senders(self) -> bool:
        """Who heard whom is kept until the moment of the links has come: linksAt, or the first takeover (the
        first choice when no linksAt is given)."""
        if self.links_at is not None:
            return "linksAt" not in self.moments
        return "takeover" not in self.moments

    def _events(self, t0: float, before: np.ndarray, after: np.ndarray) -> None:
        col = {v: i for i, v in enumerate(WATCHED)}
        for k in np.flatnonzero((before != after).any(axis=1)):
            b, a = before[k], after[k]
            if a[col["takeovers"]] > b[col["takeovers"]]:
                targets = sorted(decode_mask(a[col["taken0"]], a[col["taken1"]]))
                other = self._name(a[col["taken_from"]])
                self._emit(t0, "takeover", k, other, None,
                           f"took over target{'s' if len(targets) != 1 else ''} {', '.join(map(str, targets))} "
                           f"of {other} (its claim; it went home or was lost)")
            if a[col["drops"]] > b[col["drops"]]:
                targets = sorted(decode_mask(a[col["dropped0"]], a[col["dropped1"]]))
                other = self._name(a[col["dropped_to"]])
                self._emit(t0, "drop", k, other, None,
                           f"dropped target{'s' if len(targets) != 1 else ''} {', '.join(map(str, targets))} "
                           f"to {other} (a better bid: nearer)")
            g0, g1 = int(b[col["give_way_to"]]), int(a[col["give_way_to"]])
            if g1 != g0:
                if g1 >= 0:
                    other = self._name(g1)
                    self._emit(t0, "give_way", k, other, self._apart(k, g1),
                               f"gives way to {other} (climbs to the layer above it)")
                else:
                    self._emit(t0, "give_way_end", k, self._name(g0), self._apart(k, g0),
                               f"clear of {self._name(g0)} (back to its cruise altitude)")

    def _name(self, index) -> str | None:
        index = int(index)
        return self.names[index] if 0 <= index < len(self.names) else None

    def _apart(self, i: int, j: int) -> float | None:
        if not 0 <= j < len(self.names):
            return None
        (xi, yi, _), (xj, yj, _) = self.position(i), self.position(j)
        return math.hypot(xj - xi, yj - yi)

    def _emit(self, t0: float, event: str, k: int, other, distance, detail: str) -> None:
        x, y, z = self.position(k)
        lat = lon = alt = None
        if self.origin is not None:
            from .geodetic import to_geodetic
            lat, lon, alt = (float(v) for v in to_geodetic(self.origin, x, y, z))
        self.ctx.emit({"time": round(float(t0), 9), "type": EVENT_TYPE, "event": event, "uav": self.names[k],
                       "other": other, "x": x, "y": y, "z": z, "lat": lat, "lon": lon, "alt": alt,
                       "distance": distance, "consumed": None, "detail": detail})
        if event in LINK_MOMENTS and event not in self.moments:
            self._moment(event, t0)

    def _moment(self, why: str, t: float) -> None:
        """The links at t: the pairs with a message arriving within one period before t, and where each UAV
        was."""
        n = len(self.names)
        pairs = set()
        for t1, b in self._recent:
            if t - self.period + 1e-9 < t1 <= t + 1e-9:
                senders = np.frombuffer(b, dtype=self._read.dtype).reshape(n, SLOTS)
                pairs.update((int(r), int(senders[r, s])) for r, s in zip(*np.nonzero(senders >= 0))
                             if senders[r, s] < n)
        self.moments[why] = {
            "time": round(float(t), 9), "why": why, "period": self.period,
            "positions": {name: self.position(k) for k, name in enumerate(self.names)},
            "links": [(self.names[r], self.names[s]) for r, s in sorted(pairs)]}

    def links(self) -> dict | None:
        """The links of the moment chosen (linksAt, else the first takeover, drop or give-way): ``{"time", "why",
        "period", "positions": {uav: (x, y, z)}, "links": [(receiver, sender), ...]}``; None when none came."""
        for why in ("linksAt",) + LINK_MOMENTS:
            if why in self.moments:
                return self.moments[why]
        return None

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        if self.ctx is None:
            return {}
        c = self.channel
        out = {"channel": c, "messages": {n: self._value(f"{c}.messages_{n}") for n in FLEET},
               "near_misses": self._value(f"{c}.near_misses"), "uavs": {}}
        for k, (name, strategy) in enumerate(self.uavs.items(), start=1):
            out["uavs"][name] = {**{n: self._value(f"{c}.uav{k}_{n}") for n in PER_UAV},
                                 **{n: self._value(f"{strategy}.{n}") for n in STRATEGY_COUNTS}}
        links = self.links()
        if links is not None:
            out["links"] = {**links, "links": [list(p) for p in links["links"]]}
        if out_dir is not None:
            Path(out_dir, COMM_FILE).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
        return out
