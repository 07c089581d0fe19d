"""Scenario YAML (or the paper's configuration folder) -> SSP archive of the multi-UAV surveillance study.

``cosim-master build-scenario scenario.yaml -o scenario.ssp`` calls :func:`build_scenario`.

System written for a scenario with N UAVs (connector names: docs/uav_connectors.md)::

    uav{i}_strat --cmd, sp_x, sp_y, sp_z-------------------> uav{i}_dyn
    uav{i}_dyn   --x, y, z, vx, vy, phase------------------> uav{i}_strat
    uav{i}_dyn   --airspeed, vz, phase---------------------> uav{i}_bat
    uav{i}_bat   --consumed--------------------------------> uav{i}_strat
    wind         --wind_x, wind_y, wind_z------------------> uav{i}_dyn      (for every i)

for i = 1..N, plus ONE ``wind`` component (UavWind) shared by all dynamics when ``wind.shared`` (the
``improved`` rules: one weather condition over the whole ~1 km area, the same gusts for every UAV at the
same time), or one ``uav{i}_wind`` per UAV (the ``paper`` rules: the paper draws the wind for each UAV
before its move), each on its own random stream (``stream`` = i) of the scenario seed.  Either way a run is
reproducible and a different seed gives a different wind history.

Landing pads: the UAVs cannot all stand on the base point (they would be in contact before take-off),
so with ``takeoff: ring`` UAV i starts from and returns to its own pad, all at once; the pads lie on a
ring around the base with ``PAD_SPACING`` (8 m) between neighbours (one UAV: the base itself).  With
``takeoff: staggered`` every UAV starts from and lands on the base itself, one after the other
(``takeoff_interval`` apart; the paper's UAVs share one base).  The layout (uavstudy/layout.py) says which
pad or take-off slot each UAV gets.  ``home_x``/``home_y`` of the dynamics and the strategy are that pad.
All ENU coordinates are metres about the base (``uavsim.geodesy``).

The SSD also carries the master settings (step, stop time, algorithm, record interval and record
patterns for the trajectory) and the UAV monitor annotation (docs/uav_monitor.md).
"""
from __future__ import annotations

import json
import logging
import math
from pathlib import Path

from lxml import etree

from master.errors import ScenarioError
from master.ssp.writer import NS as SSP_NS
from master.ssp.writer import SspBuilder
from uavsim.mission_encoding import encode as encode_mission
from uavsim.params import PREFLIGHT_TIME

from .names import (BATTERY, DYNAMICS, MONITOR_CONNECTORS, MONITOR_TYPE, STRATEGY, UAV_NS, UAV_PARTS, WIND,
                    component, uav_name)
from .layout import realize
from .scenario import UavScenario, load_paper_config, load_scenario_yaml

__all__ = ["build_scenario", "build_from_paper_config", "build_ssp", "default_fmu_dir", "pad_positions",
           "monitor_annotation", "UAV_NS", "MONITOR_TYPE", "PAD_SPACING", "RECORD_PATTERNS", "PARAMETER_SET"]

log = logging.getLogger(__name__)

PAD_SPACING = 8.0          # m between neighbouring landing pads (> 3 x the 2.6 m impact diameter)
RECORD_INTERVAL = 1.0      # s, trajectory resolution of the shipped scenarios
ALTITUDE_THRESHOLD = 0.5   # m, below this height a UAV is on its pad (not checked by the monitor)
HOME_TOLERANCE = 5.0       # m, "back at base" = landed within this distance of its pad
SUCCESS_BATTERY = 0.05     # success needs more than 5 % battery left (the paper)

FMU_FILES = {DYNAMICS: "UavDynamics.fmu", BATTERY: "UavBattery.fmu", STRATEGY: "UavStrategy.fmu",
             WIND: "UavWind.fmu"}
#: the dynamics FMU of a UAV with ``vehicle: sitl`` (docs/sitl.md)
SITL_FMU = "UavSitl.fmu"
#: strategy C's channel: one component for the fleet (docs/cooperative.md)
CHANNEL, CHANNEL_FMU = "channel", "UavChannel.fmu"
#: what results.parquet records in addition with strategy C: the channel's fleet counters and what C did
COMM_RECORD = [f"{CHANNEL}.messages_*", f"{CHANNEL}.near_misses"] + \
    [f"{component('uav*', STRATEGY)}.{v}" for v in ("takeovers", "drops", "give_ways")]
#: what results.parquet records in addition for the SITL vehicles (not ``sitl_instance``: which instance number was
#: free is bookkeeping, kept in run.json by the sitl-clock monitor, so that two runs give the same results)
SITL_RECORD = [f"{component('uav*', DYNAMICS)}.{v}" for v in ("flight_mode", "armed", "ekf_ok", "slip", "max_slip",
                                                              "tilt", "motor_power", "ready_time")]

#: what results.parquet records (trajectory, battery, mission and photo outputs, wind)
RECORD_PATTERNS = (
    [f"{component('uav*', DYNAMICS)}.{v}" for v in ("x", "y", "z", "vx", "vy", "vz", "lat", "lon", "alt",
                                                    "groundspeed", "airspeed", "phase")]
    + [f"{component('uav*', BATTERY)}.{v}" for v in ("soc", "consumed", "energy_used", "power", "voltage",
                                                     "current")]
    + [f"{component('uav*', STRATEGY)}.{v}" for v in ("cmd", "sp_x", "sp_y", "mission_state", "targets_assigned",
                                                      "targets_visited", "photo_count", "last_photo_target",
                                                      "last_photo_time", "last_photo_x", "last_photo_y",
                                                      "current_target", "avoiding")]
    + [f"{WIND}.{v}" for v in ("wind_x", "wind_y", "wind_z", "wind_speed", "wind_level")]
)
WIND_OUTPUTS = ("wind_x", "wind_y", "wind_z", "wind_speed", "wind_level")


#: the one name of every component's parameter set: Ecos (ecospy) applies a parameter set only when its name
#: is passed to ``init(parameter_set=...)``, and then only the sets of that name, so per-component names
#: (SspBuilder's "<component>-parameters") would leave all but one component unparameterised there
PARAMETER_SET = "scenario"


def default_fmu_dir() -> Path:
    """The repository's ``fmus/`` folder (next to the ``uavstudy`` package)."""
    return Path(__file__).resolve().parents[1] / "fmus"


def pad_positions(n: int, spacing: float = PAD_SPACING) -> list[tuple[float, float]]:
    """ENU (east, north) of the n landing pads: the base for one UAV, else a ring around the base with
    ``spacing`` between neighbours, pad 0 due north, numbered clockwise."""
    if n <= 1:
        return [(0.0, 0.0)]
    r = spacing / (2.0 * math.sin(math.pi / n))
    out = []
    for i in range(n):
        a = 2.0 * math.pi * i / n
        out.append((round(r * math.sin(a), 6) + 0.0, round(r * math.cos(a), 6) + 0.0))
    return out


def _mm(v) -> str:
    return f"{round(float(v), 3) + 0.0:.3f}"     # + 0.0: no "-0.000"


def _pts(points, sep=";") -> str:
    return sep.join(f"{_mm(x)},{_mm(y)}" for x, y in points)


def record_patterns(shared_wind: bool) -> list[str]:
    """RECORD_PATTERNS, with the per-UAV wind components when the UAVs do not share one."""
    if shared_wind:
        return list(RECORD_PATTERNS)
    return [p for p in RECORD_PATTERNS if not p.startswith(f"{WIND}.")] + \
        [f"{component('uav*', WIND)}.{v}" for v in WIND_OUTPUTS]


def settings(scn: UavScenario, layout) -> dict:
    """The rule set and every model setting the paper leaves open, as the run's summary records them."""
    w = scn.wind
    return {"rules": scn.rules, "cruise_speed": float(scn.cruise_speed), "max_accel": float(scn.max_accel),
            "zone_planning": bool(scn.zone_planning), "lookahead": float(scn.lookahead),
            "wind_shared": bool(w.shared), "wind_effect": w.effect, "wind_episode_s": float(w.decision_interval),
            "layout": scn.layout, "layout_seed": int(scn.layout_seed), "layout_id": layout.layout_id,
            "area_scale": float(scn.area_scale), "takeoff": scn.takeoff,
            "takeoff_interval": float(scn.takeoff_interval), "battery_capacity_ah": float(scn.battery_capacity)}


def _record_interval(step: float) -> float:
    k = max(1, int(round(RECORD_INTERVAL / step)))
    return k * step if abs(k * step - RECORD_INTERVAL) > 1e-9 else RECORD_INTERVAL


def _assigned(scn: UavScenario, targets, i: int, home) -> list[int] | None:
    """The global target indices UAV i is given (computed as the strategy FMU does)."""
    try:
        from uavsim.strategy import assign_targets
    except ImportError:  # pragma: no cover - uavsim is installed with the project
        return None
    return assign_targets([tuple(map(float, p)) for p in targets], i, scn.n_uavs, scn.assignment, home)


def _warn(scn: UavScenario, message: str) -> None:
    """One line on stderr (the logging module's last-resort handler prints the bare message): the SSP is
    still written, the scenario is legal but probably not what its author meant."""
    log.warning("warning: scenario %s: %s", scn.name, message)


def _check_partition(scn: UavScenario, uavs, n_targets: int) -> None:
    """Warn when the strategies' target split is not a partition (each target to exactly one UAV).

    The strategy FMU computes the ``spatial`` sectors around its own home, i.e. around each UAV's pad,
    so for some fleet sizes a target near a sector border goes to two UAVs and another to none."""
    if not uavs or any(u["assigned"] is None for u in uavs):
        return
    got = sorted(k for u in uavs for k in u["assigned"])
    if got != list(range(n_targets)):
        twice = sorted({k for k in got if got.count(k) > 1})
        none = sorted(set(range(n_targets)) - set(got))
        _warn(scn, f"assignment {scn.assignment!r}: the UAVs' target lists are not a partition (targets {twice} "
                   f"assigned twice, {none} to no UAV), because each strategy splits around its own pad")


def _check_idle_uavs(scn: UavScenario, uavs, n_targets: int) -> None:
    """Warn about UAVs given no target: they take off, come back and end as ``no_targets``."""
    idle = [u["name"] for u in uavs if u["assigned"] == []]
    if not idle:
        return
    why = (f"{scn.n_uavs} UAVs for {n_targets} targets" if scn.n_uavs > n_targets
           else f"assignment {scn.assignment!r}")
    _warn(scn, f"{why}: {', '.join(idle)} get no target")


def _check_targets_on_base(scn: UavScenario, targets, pads) -> None:
    """Warn about targets within HOME_TOLERANCE of the base or a landing pad: a UAV "photographs" them while
    it stands on the ground or lands, which says nothing about the surveillance."""
    near = [k for k, (x, y) in enumerate(targets)
            if min(math.hypot(x - px, y - py) for px, py in [(0.0, 0.0), *pads]) <= HOME_TOLERANCE]
    if near:
        _warn(scn, f"target(s) {near} lie on the base (within {HOME_TOLERANCE:g} m of the base or a landing pad)")


def _mission_parameters(scn: UavScenario, targets, zones) -> dict:
    """The strategy's targets and zones as indexed Integer/Real parameters (uavsim/mission_encoding.py):
    every master applies those, not every one applies String parameters (Ecos does not)."""
    try:
        return encode_mission(targets, [z["polygon"] for z in zones])
    except ValueError as exc:
        raise ScenarioError(f"scenario {scn.name}: {exc}", element="targets/zones") from None


def monitor_annotation(scn: UavScenario, uavs: list[dict], targets, zones, run_settings=None) -> etree._Element:
    """The ``ssc:Annotation`` element of the UAV monitor (format: docs/uav_monitor.md)."""
    ann = etree.Element(f"{{{SSP_NS['ssc']}}}Annotation", nsmap={"ssc": SSP_NS["ssc"]}, type=MONITOR_TYPE)
    lat0, lon0, alt0 = scn.base
    mon = etree.SubElement(ann, f"{{{UAV_NS}}}UavMonitor", nsmap={"uav": UAV_NS})
    for k, v in (("version", "1.0"), ("scenario", scn.name), ("strategy", scn.strategy),
                 ("assignment", scn.assignment), ("impactDiameter", repr(float(scn.impact_diameter))),
                 ("altitudeThreshold", repr(ALTITUDE_THRESHOLD)), ("originLatitude", repr(float(lat0))),
                 ("originLongitude", repr(float(lon0))), ("originAltitude", repr(float(alt0))),
                 ("homeTolerance", repr(HOME_TOLERANCE)), ("successBattery", repr(SUCCESS_BATTERY)),
                 ("seed", str(scn.seed)), ("windProbability", repr(float(scn.wind.probability))),
                 ("endWhenAllLanded", "true" if scn.end_when_all_landed else "false")):
        mon.set(k, v)
    for u in uavs:
        el = etree.SubElement(mon, f"{{{UAV_NS}}}Uav")
        attrs = {"name": u["name"], "index": str(u["index"]), "components": " ".join(u[p] for p in UAV_PARTS),
                 "homeX": repr(u["home"][0]), "homeY": repr(u["home"][1]),
                 **{role: f"{u[part]}.{var}" for role, (part, var) in MONITOR_CONNECTORS.items()}}
        if u["assigned"] is not None:
            attrs["assigned"] = " ".join(str(k) for k in u["assigned"])
        for k, v in attrs.items():
            el.set(k, v)
    if run_settings:
        st = etree.SubElement(mon, f"{{{UAV_NS}}}Settings")
        for k, v in run_settings.items():
            st.set(k, json.dumps(v))
    t = etree.SubElement(mon, f"{{{UAV_NS}}}Targets")
    t.text = _pts(targets, " ")
    for z in zones:
        ze = etree.SubElement(mon, f"{{{UAV_NS}}}Zone", name=z["name"])
        ze.text = _pts(z["polygon"], " ")
    return ann


def _wind_params(scn: UavScenario, stream: int) -> dict:
    """UavWind's parameters; ``stream`` -1 is the fleet's one wind, i >= 0 UAV i's own draw."""
    w = scn.wind
    di = float(w.decision_interval)
    params = {
        "probability": float(w.probability), "seed": int(scn.seed), "direction_deg": float(w.direction_deg),
        "decision_interval": di, "duration": di, "ramp": min(1.0, 0.25 * di),
        "speed_weak": float(w.intensities["weak"]), "speed_moderate": float(w.intensities["moderate"]),
        "speed_strong": float(w.intensities["strong"]), "turbulence": bool(w.turbulence), "gusts": bool(w.gusts)}
    if stream >= 0:
        params["stream"] = int(stream)
    return params


def _sitl_parameters(scn: UavScenario, i: int) -> dict:
    """UavSitl's own parameters for UAV i; the binary stays unset unless the scenario names one, so that the
    SSP runs wherever $ARDUPILOT_SITL points.  The cruise speed and acceleration become the firmware's
    WPNAV_SPEED and WPNAV_ACCEL (cm/s, cm/s^2) unless ``sitl.params`` sets them."""
    o = scn.sitl
    fw = {"WPNAV_SPEED": round(100.0 * float(scn.cruise_speed), 3),
          "WPNAV_ACCEL": round(100.0 * float(scn.max_accel), 3), **o.params}
    out = {"coupling": o.coupling, "frame": o.frame, "speedup": float(o.speedup), "sysid": i + 1,
           "params": ",".join(f"{k}={v!r}" for k, v in sorted(fw.items()))}
    if o.binary:
        out["sitl_binary"] = o.binary
    if o.defaults:
        out["defaults"] = o.defaults
    if o.frame_rate:
        out["frame_rate"] = int(o.frame_rate)
    if not o.gcs_port:
        out["gcs_port"] = False
    return out


#: random layouts drawn in this process: every cell of a campaign's repetition flies the same one
_LAYOUTS: dict[tuple, object] = {}
_MAX_LAYOUTS = 64


def layout_key(scn: UavScenario) -> tuple | None:
    """Everything :func:`uavstudy.layout.realize` reads of a random-layout scenario (None: not random)."""
    if scn.layout != "random":
        return None
    return (int(scn.layout_seed), len(scn.targets), len(scn.zones), int(scn.n_uavs), float(scn.area_scale))


def _realize(scn: UavScenario):
    key = layout_key(scn)
    if key is None:
        return realize(scn)
    layout = _LAYOUTS.get(key)
    if layout is None:
        layout = realize(scn)
        for a in (layout.targets, *(z["polygon"] for z in layout.zones)):
            a.flags.writeable = False        # shared by later runs: a change would leak into them
        if len(_LAYOUTS) >= _MAX_LAYOUTS:
            _LAYOUTS.clear()
        _LAYOUTS[key] = layout
    return layout


def build_ssp(scn: UavScenario, out_path, fmu_dir=None, to_disk: bool = True) -> Path:
    """Write the SSP of a loaded scenario (``.ssp`` archive or, for another suffix, an SSP folder); ``to_disk``
    False: an archive kept in this process's memory only (``SspBuilder.write``)."""
    fmu_dir = Path(fmu_dir) if fmu_dir is not None else default_fmu_dir()
    fmus = {k: fmu_dir / f for k, f in FMU_FILES.items()}
    sitl_uavs = [i for i in range(scn.n_uavs) if scn.vehicle_of(i) == "sitl"]
    if sitl_uavs:
        fmus["sitl"] = fmu_dir / SITL_FMU
    if scn.strategy == "C":
        fmus[CHANNEL] = fmu_dir / CHANNEL_FMU
    missing = [str(p) for p in fmus.values() if not p.is_file()]
    if missing:
        raise ScenarioError(f"UAV FMU(s) not found: {', '.join(missing)} (build them with "
                            "'python fmu_sources/build_fmus.py')", file=str(fmu_dir), element="fmus")
    lat0, lon0, alt0 = scn.base
    layout = _realize(scn)
    targets = layout.targets
    zones = layout.zones
    targets_s = _pts(targets)
    zones_s = "|".join(_pts(z["polygon"]) for z in zones)
    # coordinates rounded to mm (through the String form); the FMUs and the monitor get the same values
    targets_r = [tuple(map(float, p.split(","))) for p in targets_s.split(";")] if targets_s else []
    zones_r = [{"name": z["name"], "polygon": [tuple(map(float, p.split(","))) for p in s.split(";")]}
               for z, s in zip(zones, zones_s.split("|") if zones_s else [])]
    mission = _mission_parameters(scn, targets_r, zones_r)

    b = SspBuilder(scn.name, parameter_set=PARAMETER_SET)
    b.start, b.stop, b.step = 0.0, float(scn.stop_time), float(scn.step)
    b.algorithm = scn.algorithm
    b.algorithm_options = dict(scn.algorithm_options)
    b.record_interval = _record_interval(float(scn.step))
    b.record = record_patterns(scn.wind.shared) + (SITL_RECORD if sitl_uavs else []) + \
        (COMM_RECORD if scn.strategy == "C" else [])
    if scn.wind.shared:
        b.add_component(WIND, fmus[WIND], params=_wind_params(scn, -1))
    speed, accel = float(scn.cruise_speed), float(scn.max_accel)
    pads = pad_positions(scn.n_uavs)
    uavs = []
    for i in range(scn.n_uavs):
        name = uav_name(i)
        slot = layout.order[i]
        staggered = scn.takeoff == "staggered"
        hx, hy = (0.0, 0.0) if staggered else pads[slot]
        d, bt, s = (component(name, part) for part in UAV_PARTS)
        wind = WIND if scn.wind.shared else component(name, WIND)
        if not scn.wind.shared:
            b.add_component(wind, fmus[WIND], params=_wind_params(scn, i))
        dyn = {"origin_lat": float(lat0), "origin_lon": float(lon0), "origin_alt": float(alt0),
               "home_x": float(hx), "home_y": float(hy), "takeoff_altitude": float(scn.takeoff_altitude)}
        if i in sitl_uavs:
            # SITL's wind is always an air velocity (drag): the 'push' effect has no SITL counterpart
            if staggered:   # takes off no earlier than its slot (its get-ready is spent before t = 0)
                dyn["preflight_time"] = slot * float(scn.takeoff_interval)
            b.add_component(d, fmus["sitl"], params={**dyn, **_sitl_parameters(scn, i)})
        else:
            dyn.update({"speed": speed, "accel": accel, "wind_push": scn.wind.effect == "push"})
            if staggered:       # the preflight check ends when the UAV's take-off slot comes
                dyn["preflight_time"] = PREFLIGHT_TIME + slot * float(scn.takeoff_interval)
            b.add_component(d, fmus[DYNAMICS], params=dyn)
        b.add_component(bt, fmus[BATTERY], params={"capacity_ah": float(scn.battery_capacity)})
        b.add_component(s, fmus[STRATEGY], params={
            "strategy": scn.strategy, "uav_index": i, "uav_count": int(scn.n_uavs), "assignment": scn.assignment,
            **mission, "lookahead": float(scn.lookahead),
            "zone_planning": bool(scn.zone_planning),
            # the planning clearance and the safety net's deceleration follow the vehicle: V^2/(2A) is its
            # braking distance at cruise (docs/uav_models.md)
            "plan_margin": speed * speed / (2.0 * accel), "brake_accel": accel,
            "home_x": float(hx), "home_y": float(hy), "cruise_altitude": float(scn.takeoff_altitude),
            **({"cruise_speed": speed, "comm_range": _comm_range(scn),
                                       "comm_los": bool(scn.comm.los),
                                       "lost_timeout": _lost_timeout(scn)} if scn.strategy == "C" else {})})
        for v in ("cmd", "sp_x", "sp_y", "sp_z"):
            b.connect(s, v, d, v)
        for v in ("x", "y", "z", "vx", "vy", "phase"):
            b.connect(d, v, s, v)
        for v in ("airspeed", "vz", "phase"):
            b.connect(d, v, bt, v)
        b.connect(bt, "consumed", s, "consumed")
        for v in ("wind_x", "wind_y", "wind_z"):
            b.connect(wind, v, d, v)
        uavs.append({"name": name, "index": i, DYNAMICS: d, BATTERY: bt, STRATEGY: s, "home": (float(hx), float(hy)),
                     "assigned": _assigned(scn, targets_r, i, (float(hx), float(hy)))})
    if scn.strategy == "C":
        _add_channel(b, scn, fmus[CHANNEL], uavs, zones_s)
        from .comm_monitor import comm_annotation       # what the channel carried, into run.json
        b.annotations.append(comm_annotation(CHANNEL, {u["name"]: u[STRATEGY] for u in uavs}, scn.comm.links_at))
    _check_partition(scn, uavs, len(targets_r))
    _check_idle_uavs(scn, uavs, len(targets_r))
    _check_targets_on_base(scn, targets_r, [u["home"] for u in uavs])
    b.annotations.append(monitor_annotation(scn, uavs, targets_r, zones_r, settings(scn, layout)))
    if sitl_uavs:       # the SITL vehicles' clock slip into run.json (uavstudy/sitl_clock.py)
        from .sitl_clock import sitl_clock_annotation
        b.annotations.append(sitl_clock_annotation({uavs[i][DYNAMICS]: scn.sitl.coupling for i in sitl_uavs}))
    return b.write(out_path, to_disk=to_disk)


def _comm_range(scn: UavScenario) -> float:
    """The range strategy C assumes of its radio (a perfect channel's is unlimited)."""
    return 1e9 if scn.comm.mode == "perfect" else float(scn.comm.range)


def _lost_timeout(scn: UavScenario) -> float:
    """Strategy C's silence before it counts a UAV in range as lost: long enough that a UAV in range and alive
    stays unheard with probability below 1e-3 (loss^(T / period) <= 1e-3), at least 5 s, at most 120 s."""
    c = scn.comm
    loss = 0.0 if c.mode == "perfect" else float(c.loss)
    if loss <= 0.0:
        return 5.0
    if loss >= 1.0:
        return 120.0
    return min(120.0, max(5.0, float(c.period) * math.log(1e-3) / math.log(loss) + float(c.latency)))


def _add_channel(b: SspBuilder, scn: UavScenario, fmu: Path, uavs: list[dict], zones: str) -> None:
    """Strategy C's channel (uavsim/channel.py): each UAV's broadcast in (its dynamics' position and velocity,
    its strategy's waypoint, state, target, claims, visited and clock), its k message slots out."""
    from uavsim.channel import BROADCAST_INT, BROADCAST_REAL, MESSAGE_INT, MESSAGE_REAL
    c = scn.comm
    b.add_component(CHANNEL, fmu, params={
        "mode": c.mode, "range": float(c.range), "period": float(c.period), "latency": float(c.latency),
        "loss": float(c.loss), "k": int(c.k), "seed": int(scn.seed), "line_of_sight": bool(c.los), "zones": zones,
        "n_uavs": int(scn.n_uavs), "near_miss": float(c.near_miss)})
    from_strategy = {"wx": "intent_x", "wy": "intent_y", "state": "mission_state", "target": "current_target"}
    for u in uavs:
        port = f"uav{u['index'] + 1}"
        for v in BROADCAST_REAL + BROADCAST_INT:
            if v in ("x", "y", "z", "vx", "vy"):
                b.connect(u[DYNAMICS], v, CHANNEL, f"{port}_{v}")
            else:
                b.connect(u[STRATEGY], from_strategy.get(v, v), CHANNEL, f"{port}_{v}")
        for slot in range(1, int(c.k) + 1):
            for v in MESSAGE_REAL + MESSAGE_INT:
                b.connect(CHANNEL, f"{port}_m{slot}_{v}", u[STRATEGY], f"m{slot}_{v}")


def build_scenario(yaml_path, out_path, fmu_dir=None) -> Path:
    """Load a YAML scenario (``ssp/scenarios/*.yaml``) and write its SSP; returns the written path."""
    return build_ssp(load_scenario_yaml(yaml_path), out_path, fmu_dir)


def build_from_paper_config(folder, out_path, fmu_dir=None) -> Path:
    """Import the paper's configuration folder (docs/paper_config_format.md) and write its SSP."""
    return build_ssp(load_paper_config(folder), out_path, fmu_dir)
