"""The UAV monitor's configuration: the ``uav:UavMonitor`` annotation read into a :class:`MonitorConfig`.

Format: docs/uav_monitor.md ("The annotation"), written by ``uavstudy.build``.  Every error is a one-line
``ScenarioError`` naming the element and line, raised before anything runs.  The step (``uavstudy.monitor_step``)
and the plug-in (``uavstudy.monitor``) only read the parsed values.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from master.errors import ScenarioError
from master.values import parse_boolean

from .names import MONITOR_TYPE, OPTIONAL_ROLES, REQUIRED_ROLES, WIND


@dataclass
class UavSpec:
    name: str
    index: int
    components: list[str]
    home: tuple[float, float]
    vars: dict[str, str]                  # role -> qualified variable
    assigned: list[int] | None = None     # global target indices given to this UAV, if known


@dataclass
class MonitorConfig:
    uavs: list[UavSpec]
    targets: np.ndarray                   # (K, 2) ENU m, map order
    zones: list[dict]                     # {"name", "polygon": (M, 2)}
    impact_diameter: float = 2.6
    altitude_threshold: float = 0.5
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    home_tolerance: float = 5.0
    success_battery: float = 0.05
    end_when_done: bool = False           # end the run once every UAV has landed after flying, or is removed
    scenario: str = ""
    strategy: str = ""
    assignment: str = ""
    seed: str = ""
    wind_probability: str = ""
    settings: dict = field(default_factory=dict)   # the rule set and model settings (uav:Settings), for summary.json


def _local(el) -> str:
    return etree.QName(el).localname if isinstance(el.tag, str) else ""


def _points(text: str, what: str, shown_as: str) -> np.ndarray:
    pts = []
    for item in (text or "").replace(";", " ").split():
        try:
            a, b = item.split(",")
            pts.append((float(a), float(b)))
        except ValueError:
            raise ScenarioError(f"expected 'x,y' points separated by blanks, got {item!r}", file=shown_as,
                                element=what) from None
    return np.asarray(pts, dtype=float).reshape(-1, 2)


def parse_config(element, shown_as: str = "") -> MonitorConfig:
    """Read the ``uav:UavMonitor`` element (inside the ``ssc:Annotation``); errors are ScenarioErrors."""
    mon = element if _local(element) == "UavMonitor" else None
    if mon is None:
        for ch in element:
            if _local(ch) == "UavMonitor":
                mon = ch
                break
    if mon is None:
        raise ScenarioError(f"annotation {MONITOR_TYPE} has no uav:UavMonitor element", file=shown_as,
                            element="Annotation")

    def num(el, attr, default, where):
        v = el.get(attr)
        if v is None:
            return default
        try:
            return float(v)
        except ValueError:
            raise ScenarioError(f"{attr}={v!r} is not a number", file=shown_as, element=where,
                                line=el.sourceline) from None

    uavs, names = [], set()
    zones, targets = [], np.empty((0, 2))
    settings: dict = {}
    for ch in mon:
        tag = _local(ch)
        if tag == "Uav":
            name = ch.get("name")
            where = f"uav:Uav {name}" if name else "uav:Uav"
            missing = [a for a in ("name", "components") + REQUIRED_ROLES if not ch.get(a)]
            if missing:
                raise ScenarioError(f"missing attribute(s) {', '.join(missing)}", file=shown_as, element=where,
                                    line=ch.sourceline)
            if name in names:
                raise ScenarioError(f"duplicate UAV name {name!r}", file=shown_as, element=where,
                                    line=ch.sourceline)
            names.add(name)
            roles = {r: ch.get(r) for r in REQUIRED_ROLES + OPTIONAL_ROLES if ch.get(r)}
            assigned = None
            if ch.get("assigned") is not None:
                try:
                    assigned = [int(k) for k in ch.get("assigned").split()]
                except ValueError:
                    raise ScenarioError(f"assigned={ch.get('assigned')!r} is not a list of target indices",
                                        file=shown_as, element=where, line=ch.sourceline) from None
            uavs.append(UavSpec(name, int(num(ch, "index", len(uavs), where)), ch.get("components").split(),
                                (num(ch, "homeX", 0.0, where), num(ch, "homeY", 0.0, where)), roles, assigned))
        elif tag == "Zone":
            poly = _points(ch.text, f"uav:Zone {ch.get('name', '')}", shown_as)
            if len(poly) < 3:
                raise ScenarioError("a zone needs at least 3 'x,y' vertices", file=shown_as,
                                    element=f"uav:Zone {ch.get('name', '')}", line=ch.sourceline)
            zones.append({"name": ch.get("name") or f"zone{len(zones) + 1}", "polygon": poly})
        elif tag == "Targets":
            targets = _points(ch.text, "uav:Targets", shown_as)
        elif tag == "Settings":
            settings = {k: _setting(v) for k, v in ch.attrib.items()}
    if not uavs:
        raise ScenarioError("uav:UavMonitor lists no uav:Uav", file=shown_as, element="uav:UavMonitor",
                            line=mon.sourceline)
    d = num(mon, "impactDiameter", 2.6, "uav:UavMonitor")
    if not d > 0:
        raise ScenarioError(f"impactDiameter must be > 0, got {d:g}", file=shown_as, element="uav:UavMonitor")
    try:
        end_when_done = parse_boolean(mon.get("endWhenAllLanded", "false"))
    except ValueError:
        raise ScenarioError(f"endWhenAllLanded={mon.get('endWhenAllLanded')!r} is not true or false", file=shown_as,
                            element="uav:UavMonitor", line=mon.sourceline) from None
    return MonitorConfig(
        uavs=uavs, targets=targets, zones=zones, impact_diameter=d,
        altitude_threshold=num(mon, "altitudeThreshold", 0.5, "uav:UavMonitor"),
        origin=(num(mon, "originLatitude", 0.0, "uav:UavMonitor"), num(mon, "originLongitude", 0.0, "uav:UavMonitor"),
                num(mon, "originAltitude", 0.0, "uav:UavMonitor")),
        home_tolerance=num(mon, "homeTolerance", 5.0, "uav:UavMonitor"),
        success_battery=num(mon, "successBattery", 0.05, "uav:UavMonitor"),
        end_when_done=end_when_done,
        scenario=mon.get("scenario", ""), strategy=mon.get("strategy", ""), assignment=mon.get("assignment", ""),
        seed=mon.get("seed", ""), wind_probability=mon.get("windProbability", ""), settings=settings)


def _setting(text: str):
    """A uav:Settings value: JSON as the builder writes it, else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def run_seed(plan, default: str) -> str:
    """The wind's seed as the run set it.  The annotation's ``seed`` is the one the SSP was built with, but
    ``cosim-master run --seed`` (and campaign runs) override the parameter: ``plan.params`` lists the SSD's
    values and then the overrides, and the last entry of a variable is the value the FMU gets."""
    seed = default
    for var, value, _origin in plan.params:
        if var.name == "seed" and (var.component == WIND or var.component.endswith(f"_{WIND}")):
            seed = str(value)
    return seed


def check_against_plan(cfg: MonitorConfig, plan, shown_as: str) -> None:
    """Every component and variable the annotation names exists in the system (a one-line error if not)."""
    fmus = getattr(plan, "fmus", None)
    for u in cfg.uavs:
        for c in u.components:
            if fmus is not None and c not in fmus:
                raise ScenarioError(f"UAV {u.name}: no component {c!r}", file=shown_as, element="uav:UavMonitor")
        for role, q in u.vars.items():
            try:
                plan.var(q)
            except (KeyError, ValueError, TypeError):
                raise ScenarioError(f"UAV {u.name}: {role}={q!r} is not a variable of the system",
                                    file=shown_as, element="uav:UavMonitor") from None
