"""How closely each ArduPilot SITL vehicle's clock kept to the master's, into run.json (docs/sitl.md).

The SITL vehicle FMU reports after every step its ``slip`` (vehicle clock minus the master's t+h: in paced
coupling how far SITL ran past the communication point, in lock-step what whole physics frames cannot hit)
and ``ready_time`` (vehicle time spent getting ready before t = 0).  This monitor, switched on by the
annotation ``org.cosim-master.sitl-clock`` that ``uavstudy.build`` writes for scenarios with SITL vehicles,
reads them after every master step and returns per vehicle::

    {"coupling": "paced", "steps": 9926, "max_slip_s": 0.093, "mean_slip_s": 0.012, "p95_slip_s": 0.031,
     "ready_time_s": 41.9, "sitl_instance": 2}

which the engine stores under ``monitors["org.cosim-master.sitl-clock"]`` in run.json, without knowing what
a SITL is.  Slips are absolute values; a removed (collided) vehicle stops counting.  ``sitl_instance`` (the
instance number N that was free on the machine: ports 5760+10N) is bookkeeping of where the vehicle ran, not
what it did, so it is kept here and not in the recorded results: two runs of one scenario and seed give the same
results.parquet whichever instances they got.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from lxml import etree

from master.errors import ScenarioError
from master.monitors import Monitor, register
from master.ssp.writer import NS as SSP_NS

SITL_CLOCK_TYPE = "org.cosim-master.sitl-clock"
SITL_NS = "https://cosim-master.org/ssp/sitl"

__all__ = ["SitlClockMonitor", "sitl_clock_annotation", "SITL_CLOCK_TYPE"]

#: the SITL vehicle's outputs this monitor reads after every step
WATCHED = ("slip", "ready_time", "sitl_instance")


def sitl_clock_annotation(vehicles: dict[str, str]) -> etree._Element:
    """The ``ssc:Annotation`` switching the monitor on for ``{component: coupling}``."""
    ann = etree.Element(f"{{{SSP_NS['ssc']}}}Annotation", nsmap={"ssc": SSP_NS["ssc"]}, type=SITL_CLOCK_TYPE)
    root = etree.SubElement(ann, f"{{{SITL_NS}}}SitlClock", nsmap={"sitl": SITL_NS})
    for component, coupling in vehicles.items():
        etree.SubElement(root, f"{{{SITL_NS}}}Vehicle", component=component, coupling=coupling)
    return ann


def _vehicles(element, shown_as: str) -> dict[str, str]:
    found = {}
    for el in element.iter():
        if isinstance(el.tag, str) and etree.QName(el).localname == "Vehicle":
            name = el.get("component")
            if not name:
                raise ScenarioError("sitl:Vehicle without a 'component'", file=shown_as, element="sitl:SitlClock")
            found[name] = el.get("coupling", "")
    if not found:
        raise ScenarioError(f"annotation {SITL_CLOCK_TYPE} names no sitl:Vehicle", file=shown_as,
                            element="sitl:SitlClock")
    return found


@register(SITL_CLOCK_TYPE)
class SitlClockMonitor(Monitor):
    def __init__(self, element, plan, shown_as: str):
        super().__init__(element, plan, shown_as)
        self.vehicles = _vehicles(element, shown_as)
        if plan is not None:
            for c in self.vehicles:
                for v in WATCHED:
                    try:
                        plan.var(f"{c}.{v}")
                    except (KeyError, ValueError, TypeError):
                        raise ScenarioError(f"{c}.{v} is not a variable of the system (not a SITL vehicle?)",
                                            file=shown_as, element="sitl:SitlClock") from None
        self.slips: list[list[float]] = [[] for _ in self.vehicles]
        self.ready = [float("nan")] * len(self.vehicles)
        self.instance = [-1] * len(self.vehicles)
        self.ctx = None

    def required_variables(self) -> list[str]:
        return [f"{c}.{v}" for c in self.vehicles for v in WATCHED]

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx
        self._where = [(*(ctx.position(f"{c}.{v}") for v in WATCHED), ctx.rt.index[c]) for c in self.vehicles]

    def after_step(self, n: int, t0: float, t1: float) -> None:
        rt = self.ctx.rt
        for k, ((ts, js), (tr, jr), (ti, ji), ci) in enumerate(self._where):
            if not rt.active[ci]:
                continue
            self.slips[k].append(abs(float(self.ctx.buffer(ts)[js])))
            self.ready[k] = float(self.ctx.buffer(tr)[jr])
            self.instance[k] = int(self.ctx.buffer(ti)[ji])

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        out = {}
        for k, (c, coupling) in enumerate(self.vehicles.items()):
            s = np.asarray(self.slips[k], dtype=float)
            info = {"coupling": coupling, "steps": int(s.size)}
            if s.size:
                info.update({"max_slip_s": float(s.max()), "mean_slip_s": float(s.mean()),
                             "p95_slip_s": float(np.percentile(s, 95))})
            if self.ready[k] == self.ready[k]:
                info["ready_time_s"] = self.ready[k]
            if self.instance[k] >= 0:
                info["sitl_instance"] = self.instance[k]
            out[c] = info
        return {"vehicles": out}
