"""What strategy C's channel carried, into run.json and ``comm.json`` (docs/cooperative.md).

The channel FMU (fmu_sources/UavChannel.py) counts the messages itself -- sent, received, lost, out of range,
blocked by a zone, dropped beyond the k nearest -- and the near misses of the fleet; the strategies count their
takeovers, drops and give-ways.  This monitor, switched on by the annotation ``org.cosim-master.uav-comm`` that
``uavstudy.build`` writes for strategy C, reads those outputs once, when the run ends, and returns::

    {"channel": "channel", "messages": {"sent": 3520, "received": 9631, "lost": 1060, "out_of_range": 0, ...},
     "near_misses": 3, "uavs": {"uav1": {"sent": 880, "received": 2411, "lost": 262, "takeovers": 0, ...}, ...}}

which the engine stores under ``monitors["org.cosim-master.uav-comm"]`` in run.json; the same goes to
``comm.json`` in the run folder.  It does nothing per step (the UAV monitor's step is untouched): a counter is
the FMU's own total, so its last value is the answer.
"""
from __future__ import annotations

import json
from pathlib import Path

from lxml import etree

from master.errors import ScenarioError
from master.monitors import Monitor, register
from master.ssp.writer import NS as SSP_NS

COMM_TYPE = "org.cosim-master.uav-comm"
COMM_NS = "https://cosim-master.org/ssp/uav-comm"
COMM_FILE = "comm.json"
FLEET = ("sent", "received", "lost", "out_of_range", "blocked", "overflow")
PER_UAV = ("sent", "received", "lost")
STRATEGY_COUNTS = ("takeovers", "drops", "give_ways")

__all__ = ["CommMonitor", "comm_annotation", "COMM_TYPE", "COMM_FILE"]


def comm_annotation(channel: str, uavs: dict[str, str]) -> etree._Element:
    """The ``ssc:Annotation`` switching the monitor on: the channel component and ``{uav name: strategy
    component}`` in channel port order (uav1, uav2, ...)."""
    ann = etree.Element(f"{{{SSP_NS['ssc']}}}Annotation", nsmap={"ssc": SSP_NS["ssc"]}, type=COMM_TYPE)
    root = etree.SubElement(ann, f"{{{COMM_NS}}}Comm", nsmap={"comm": COMM_NS}, channel=channel)
    for name, strategy in uavs.items():
        etree.SubElement(root, f"{{{COMM_NS}}}Uav", name=name, strategy=strategy)
    return ann


def _read(element, shown_as: str) -> tuple[str, dict[str, str]]:
    channel, uavs = None, {}
    for el in element.iter():
        if not isinstance(el.tag, str):
            continue
        local = etree.QName(el).localname
        if local == "Comm":
            channel = el.get("channel")
        elif local == "Uav":
            if not el.get("name") or not el.get("strategy"):
                raise ScenarioError("comm:Uav needs 'name' and 'strategy'", file=shown_as, element="comm:Comm")
            uavs[el.get("name")] = el.get("strategy")
    if not channel:
        raise ScenarioError(f"annotation {COMM_TYPE} names no channel component", file=shown_as,
                            element="comm:Comm")
    return channel, uavs


@register(COMM_TYPE)
class CommMonitor(Monitor):
    def __init__(self, element, plan, shown_as: str):
        super().__init__(element, plan, shown_as)
        self.channel, self.uavs = _read(element, shown_as)
        self.ctx = None
        self._last = None
        if plan is not None:
            for v in self.required_variables():
                try:
                    plan.var(v)
                except (KeyError, ValueError, TypeError):
                    raise ScenarioError(f"{v} is not a variable of the system (not a UavChannel / UavStrategy?)",
                                        file=shown_as, element="comm:Comm") from None

    def required_variables(self) -> list[str]:
        c = self.channel
        names = [f"{c}.messages_{n}" for n in FLEET] + [f"{c}.near_misses"]
        for k, (name, strategy) in enumerate(self.uavs.items(), start=1):
            names += [f"{c}.uav{k}_{n}" for n in PER_UAV] + [f"{strategy}.{n}" for n in STRATEGY_COUNTS]
        return names

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx
        self._where = {v: ctx.position(v) for v in self.required_variables()}

    def _value(self, name: str) -> int:
        typ, j = self._where[name]
        return int(self.ctx.buffer(typ)[j])

    def after_step(self, n: int, t0: float, t1: float) -> None:
        pass

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        if self.ctx is None:
            return {}
        c = self.channel
        out = {"channel": c, "messages": {n: self._value(f"{c}.messages_{n}") for n in FLEET},
               "near_misses": self._value(f"{c}.near_misses"), "uavs": {}}
        for k, (name, strategy) in enumerate(self.uavs.items(), start=1):
            out["uavs"][name] = {**{n: self._value(f"{c}.uav{k}_{n}") for n in PER_UAV},
                                 **{n: self._value(f"{strategy}.{n}") for n in STRATEGY_COUNTS}}
        if out_dir is not None:
            Path(out_dir, COMM_FILE).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
        return out
