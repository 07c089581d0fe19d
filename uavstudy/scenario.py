"""Multi-UAV surveillance scenario: YAML model and import of the paper's configuration files.

Two sources produce the same :class:`UavScenario`:

* ``load_scenario_yaml(path)``: the project's YAML scenario (see
  ``ssp/scenarios/*.yaml``);
* ``load_paper_config(folder)``: the paper's three files ``init.properties``,
  ``targets.txt`` and ``restrictedAreas.txt`` (format defined in
  ``docs/paper_config_format.md``, the paper gives none).

Every invalid field raises :class:`master.errors.ScenarioError` whose ``str``
is one line ``"<path>: <field>: <reason>"`` (``field`` is a dotted path such
as ``wind.intensities.strong`` or ``targets[3]``, or ``line N`` / a property
key for the paper files).

Geographic coordinates are WGS84 degrees; altitudes metres above the
ellipsoid; local coordinates are ENU metres about the base
(``uavsim.geodesy``).  No FMU or SSP is written here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import yaml

from master import yamlio
from master.errors import ScenarioError
from uavsim.geodesy import enu_from_geodetic
from uavsim.mission_encoding import MAX_TARGETS, MAX_ZONE_VERTICES, MAX_ZONES

__all__ = ["UavScenario", "WindConfig", "SitlOptions", "CommConfig", "VEHICLES", "ScenarioError", "load_scenario_yaml", "scenario_from_dict",
           "load_paper_config", "scenario_to_dict", "dump_scenario_yaml",
           "STRATEGIES", "ASSIGNMENTS", "MAX_RANGE_M", "RULE_SETS", "LAYOUTS", "TAKEOFFS", "WIND_EFFECTS"]

STRATEGIES = ("A", "B", "C")
ASSIGNMENTS = ("equal", "spatial")
WIND_LEVELS = ("weak", "moderate", "strong")
LAYOUTS = ("fixed", "random")
TAKEOFFS = ("ring", "staggered")
WIND_EFFECTS = ("drag", "push")

#: The two named rule sets (docs/campaigns.md, "Rule sets"): the values a scenario takes for the fields it does
#: not give itself.  ``improved`` is the project's model as it was before rule sets existed (every shipped
#: scenario builds and runs bit-identically under it); ``paper`` is what the paper states and the defaults of
#: the autopilot of its era (docs/uav_models.md, "The paper's rules").  A field given in the scenario wins.
RULE_SETS: dict[str, dict[str, Any]] = {
    "improved": {"cruise_speed": 10.0, "max_accel": 2.5, "zone_planning": True,
                 "wind.shared": True, "wind.effect": "drag", "wind.decision_interval": 1.0},
    # ArduCopter 3.x-4.0 (the paper's era): WPNAV_SPEED 500 cm/s, WPNAV_ACCEL 100 cm/s/s; the paper's late
    # 2 m detection without planning; wind drawn per UAV, pushing it (docs/uav_models.md)
    "paper": {"cruise_speed": 5.0, "max_accel": 1.0, "zone_planning": False,
              "wind.shared": False, "wind.effect": "push", "wind.decision_interval": 10.0},
}
#: targets and zone vertices must lie within this distance of the base (the
#: geodesy error bound is stated for 50 km)
MAX_RANGE_M = 50_000.0


def _default_intensities() -> dict[str, float]:
    return {"weak": 3.0, "moderate": 6.0, "strong": 9.0}


@dataclass
class WindConfig:
    """Wind model settings.

    ``probability``: probability in [0, 1] that wind blows in a decision
    interval (the paper sweeps 0 %..15 %); when it blows, the level weak /
    moderate / strong is drawn uniformly and its speed taken from
    ``intensities`` (m/s).  ``direction_deg``: meteorological direction the
    wind comes FROM, degrees clockwise from north (default 90: from the east,
    i.e. pushing the UAVs west as in the paper).  ``decision_interval``: s
    between draws (each episode lasts the whole interval).  ``turbulence``/``gusts``: optional extra
    effects.  ``shared``: one wind for all UAVs, else one independent draw per UAV.  ``effect``: ``drag``
    (air velocity in the drag law, rejected by the autopilot) or ``push`` (the paper's "force that pushes
    the UAV": the vehicle is carried at the wind velocity, its position controller flies it back).
    """
    probability: float = 0.0
    intensities: dict[str, float] = field(default_factory=_default_intensities)
    direction_deg: float = 90.0
    decision_interval: float = 1.0
    turbulence: bool = False
    gusts: bool = False
    shared: bool = True              # one wind for the whole fleet (false: each UAV draws its own)
    effect: str = "drag"             # drag: air velocity the controller rejects; push: carries the UAV


VEHICLES = ("point_mass", "sitl")
COUPLINGS = ("lockstep", "paced")
FRAMES = ("x", "+")


@dataclass
class SitlOptions:
    """How the UAVs with ``vehicle: sitl`` are flown (docs/sitl.md).

    ``coupling``: ``lockstep`` (SITL's physics is ours, answered frame by frame: deterministic) or ``paced``
    (SITL's own physics at SIM_SPEEDUP: not deterministic).  ``frame``: motor layout x or +.  ``speedup``:
    paced mode's largest SIM_SPEEDUP.  ``params``: extra firmware parameters.  ``binary``/``defaults``: the
    arducopter executable and its defaults file (default: $ARDUPILOT_SITL and the copter.parm next to it).
    ``frame_rate``: physics frames per second (0: the firmware's 1200; a lower rate needs SCHED_LOOP_RATE at
    most rate / 1.8 in ``params`` and flies a different flight).  ``gcs_port``: false for a headless fleet (no
    SERIAL1/SERIAL2 ground-station ports; ``--mavlink`` then cannot forward the firmware's stream).
    """
    coupling: str = "lockstep"
    frame: str = "x"
    speedup: float = 50.0
    params: dict[str, float] = field(default_factory=dict)
    binary: str = ""
    defaults: str = ""
    frame_rate: int = 0
    gcs_port: bool = True


COMM_MODES = ("radio", "perfect", "none")


@dataclass
class CommConfig:
    """The UAV-to-UAV channel strategy C listens to (docs/cooperative.md; uavsim/channel.py).

    ``mode``: ``radio`` (the parameters below), ``perfect`` (unlimited range, no loss, no latency) or ``none``
    (nothing is sent: C flies as B).  ``range`` m (3-D distance at sending), ``period`` s between a UAV's
    broadcasts, ``latency`` s, ``loss`` probability per message and receiver (drawn from the scenario seed),
    ``k`` messages a UAV takes per step (nearest senders first), ``los``: restricted zones block the line of
    sight, ``near_miss`` m: the distance counted as a near miss; ``links_at`` s: the moment whose links (who heard
    whom) map.png draws (None: the first takeover, drop or give-way).  Only strategy C builds the channel; the
    section is ignored for A and B (so that one campaign grid may cross strategies with channel axes)."""
    mode: str = "radio"
    range: float = 300.0
    period: float = 1.0
    latency: float = 0.0
    loss: float = 0.0
    k: int = 4
    los: bool = False
    near_miss: float = 10.0
    links_at: float | None = None


@dataclass
class UavScenario:
    """A multi-UAV surveillance mission (see module docstring for units)."""
    name: str
    base: tuple[float, float, float]                 # lat, lon (deg), alt (m)
    n_uavs: int
    strategy: str                                    # "A" | "B"
    targets: list[tuple[float, float]]               # (lat, lon), base excluded
    takeoff_altitude: float = 20.0                   # m above the base
    assignment: str = "equal"                        # "equal" | "spatial"
    zones: list[dict] = field(default_factory=list)  # {"name": str, "polygon": [(lat, lon), ...]}
    wind: WindConfig = field(default_factory=WindConfig)
    seed: int = 0
    step: float = 0.1                                # s, co-simulation macro step
    stop_time: float = 1500.0                        # s
    impact_diameter: float = 2.6                     # m (paper)
    lookahead: float = 2.0                           # m, zone detection distance (paper)
    algorithm: str = "jacobi"
    # end the run once every UAV has landed or been removed (the shipped SSPs do): the outputs are the same,
    # the idle rest up to stop_time is skipped; false = run to stop_time
    end_when_all_landed: bool = True
    zone_planning: bool = True                       # plan legs around zones (false: the paper's late detection)
    # the co-simulation algorithm's settings (master.algorithm_options: extrapolation, coupling_tol, ...),
    # written into the SSD's settings annotation
    algorithm_options: dict = field(default_factory=dict)
    rules: str = "improved"                          # the rule set giving the defaults (RULE_SETS)
    cruise_speed: float = 10.0                       # m/s horizontal waypoint speed (WPNAV_SPEED)
    max_accel: float = 2.5                           # m/s^2 horizontal acceleration (WPNAV_ACCEL)
    layout: str = "fixed"                            # fixed: the given targets/zones; random: drawn (layout.py)
    layout_seed: int = 0                             # the random layout's seed (a campaign sets it per repetition)
    area_scale: float = 1.0                          # targets and zones scaled about the base
    takeoff: str = "ring"                            # ring: pads 8 m apart, all at once; staggered: one base
    takeoff_interval: float = 15.0                   # s between staggered take-offs
    battery_capacity: float = 5.1                    # Ah per UAV (3DR Iris+ 5100 mAh)
    # what flies each UAV: "point_mass" (UavDynamics.fmu) or "sitl" (UavSitl.fmu, ArduPilot SITL), fleet-wide
    # or one entry per UAV
    vehicle: str | list = "point_mass"
    sitl: SitlOptions = field(default_factory=SitlOptions)
    comm: CommConfig = field(default_factory=CommConfig)   # the channel of strategy C

    def vehicle_of(self, index: int) -> str:
        """The vehicle kind of the UAV with 0-based ``index``."""
        return self.vehicle[index] if isinstance(self.vehicle, list) else self.vehicle

    # ----------------------------------------------------------- local frame
    def targets_enu(self) -> np.ndarray:
        """(K, 2) east, north [m] of the targets about the base."""
        if not self.targets:
            return np.empty((0, 2))
        t = np.asarray(self.targets, dtype=float)
        lat0, lon0, alt0 = self.base
        e, n, _ = enu_from_geodetic(t[:, 0], t[:, 1], alt0, lat0, lon0, alt0)
        return np.column_stack((e, n))

    def zones_enu(self) -> list[dict]:
        """Zones as ``[{"name": str, "polygon": (M, 2) array of east, north [m]}]``."""
        lat0, lon0, alt0 = self.base
        out = []
        for z in self.zones:
            p = np.asarray(z["polygon"], dtype=float)
            e, n, _ = enu_from_geodetic(p[:, 0], p[:, 1], alt0, lat0, lon0, alt0)
            out.append({"name": z["name"], "polygon": np.column_stack((e, n))})
        return out


# ============================================================== validation
class _V:
    """Field validators raising one-line ScenarioErrors for one source file."""

    def __init__(self, path):
        self.path = str(path)

    def fail(self, fld: str, reason: str):
        raise ScenarioError(reason, file=self.path, element=fld)

    def number(self, fld, v, *, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(fld, f"expected a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            self.fail(fld, f"must be finite, got {v!r}")
        if lo is not None and (v <= lo if lo_open else v < lo):
            self.fail(fld, f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
        if hi is not None and (v >= hi if hi_open else v > hi):
            self.fail(fld, f"must be {'<' if hi_open else '<='} {hi:g}, got {v:g}")
        return v

    def integer(self, fld, v, *, lo=None) -> int:
        if isinstance(v, bool) or not (isinstance(v, int) or
                                       (isinstance(v, float) and v.is_integer())):
            self.fail(fld, f"expected an integer, got {v!r}")
        v = int(v)
        if lo is not None and v < lo:
            self.fail(fld, f"must be >= {lo}, got {v}")
        return v

    def boolean(self, fld, v) -> bool:
        if not isinstance(v, bool):
            self.fail(fld, f"expected true or false, got {v!r}")
        return v

    def choice(self, fld, v, options) -> str:
        if not isinstance(v, str) or v not in options:
            self.fail(fld, f"must be one of {', '.join(options)}, got {v!r}")
        return v

    def text(self, fld, v) -> str:
        if not isinstance(v, str) or not v.strip():
            self.fail(fld, f"expected a non-empty string, got {v!r}")
        return v.strip()

    def latlon(self, fld, v) -> tuple[float, float]:
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            self.fail(fld, f"expected [lat, lon], got {v!r}")
        return (self.number(fld + ".lat", v[0], lo=-90, hi=90),
                self.number(fld + ".lon", v[1], lo=-180, hi=180))

    def mapping(self, fld, v) -> dict:
        if not isinstance(v, dict):
            self.fail(fld, f"expected a mapping, got {type(v).__name__}")
        return v

    def no_unknown(self, fld, d, known):
        for k in d:
            if k not in known:
                where = f"{fld}.{k}" if fld else str(k)
                self.fail(where, f"unknown field (expected one of {', '.join(known)})")


_TOP_FIELDS = [f.name for f in fields(UavScenario)]
_REQUIRED = ("name", "base", "n_uavs", "strategy", "targets")
# the strategy FMU takes the mission as indexed scalar parameters, a fixed number of them
#: the largest fleet a scenario file may ask for: 16 times the largest studied (256, bench/bench_uav_scaling.py)
MAX_UAVS = 4096
_FMU_LIMIT = "(the strategy FMU's indexed parameters, docs/uav_models.md)"
_WIND_FIELDS = [f.name for f in fields(WindConfig)]


def _check_geometry(v: _V, scn: UavScenario, where: dict[str, str]):
    """Cross-field checks: range from the base, polygon validity, zones clear of targets/base."""
    lat0, lon0, alt0 = scn.base
    enu = scn.targets_enu()
    if enu.size:
        d = np.hypot(enu[:, 0], enu[:, 1])
        k = int(np.argmax(d))
        if d[k] > MAX_RANGE_M:
            v.fail(where["target"](k), f"{d[k] / 1e3:.1f} km from the base (max {MAX_RANGE_M / 1e3:g} km)")
    names = set()
    for zi, z in enumerate(scn.zones_enu()):
        if z["name"] in names:
            v.fail(where["zone_name"](zi), f"duplicate zone name {z['name']!r}")
        names.add(z["name"])
        p = z["polygon"]
        d = np.hypot(p[:, 0], p[:, 1])
        if d.max() > MAX_RANGE_M:
            v.fail(where["zone"](zi), f"{d.max() / 1e3:.1f} km from the base (max {MAX_RANGE_M / 1e3:g} km)")
        poly = shapely.Polygon(p)
        if not poly.is_valid or poly.area <= 0:
            reason = shapely.is_valid_reason(poly) if poly.area > 0 else "zero area"
            v.fail(where["zone"](zi), f"invalid polygon ({reason})")
        if poly.intersects(shapely.Point(0.0, 0.0)):
            v.fail(where["zone"](zi), "covers the base")
        if enu.size:
            inside = shapely.intersects_xy(poly, enu[:, 0], enu[:, 1])
            if inside.any():
                v.fail(where["zone"](zi), f"covers target {int(np.flatnonzero(inside)[0])} "
                                          "(a target in a restricted zone cannot be visited)")


def _rule_fields(v: _V, data: dict, kw: dict) -> None:
    """The fields a rule set gives defaults for, and the model settings the paper leaves open."""
    rules = kw["rules"] = v.choice("rules", data.get("rules", "improved"), tuple(RULE_SETS))
    defaults = RULE_SETS[rules]
    wind = kw.setdefault("wind", WindConfig())
    given_wind = data.get("wind") if isinstance(data.get("wind"), dict) else {}
    for key, value in defaults.items():
        if key.startswith("wind."):
            if key[5:] not in given_wind:
                setattr(wind, key[5:], value)
        elif key not in data:
            kw[key] = value
    if "zone_planning" in data:
        kw["zone_planning"] = v.boolean("zone_planning", data["zone_planning"])
    if "cruise_speed" in data:
        kw["cruise_speed"] = v.number("cruise_speed", data["cruise_speed"], lo=0.5, hi=20)
    if "max_accel" in data:
        kw["max_accel"] = v.number("max_accel", data["max_accel"], lo=0.1, hi=5)
    if "layout" in data:
        kw["layout"] = v.choice("layout", data["layout"], LAYOUTS)
    if "layout_seed" in data:
        kw["layout_seed"] = v.integer("layout_seed", data["layout_seed"], lo=0)
    if "area_scale" in data:
        kw["area_scale"] = v.number("area_scale", data["area_scale"], lo=0.1, hi=10)
    if "takeoff" in data:
        kw["takeoff"] = v.choice("takeoff", data["takeoff"], TAKEOFFS)
    if "takeoff_interval" in data:
        kw["takeoff_interval"] = v.number("takeoff_interval", data["takeoff_interval"], lo=0, hi=600)
    if "battery_capacity" in data:
        kw["battery_capacity"] = v.number("battery_capacity", data["battery_capacity"], lo=0.1, lo_open=False,
                                          hi=100)


def scenario_from_dict(data: Any, path) -> UavScenario:
    """Validate the fields of a scenario (as read from YAML); ``path`` names the file in errors."""
    v = _V(path)
    if not isinstance(data, dict):
        v.fail("(top level)", f"expected a mapping of scenario fields, got {type(data).__name__}")
    v.no_unknown("", data, _TOP_FIELDS)
    for k in _REQUIRED:
        if k not in data:
            v.fail(k, "missing required field")
    kw: dict[str, Any] = {}
    kw["name"] = v.text("name", data["name"])
    b = data["base"]
    if isinstance(b, dict):
        v.no_unknown("base", b, ("lat", "lon", "alt"))
        b = [b.get("lat"), b.get("lon"), b.get("alt", 0.0)]
    if not isinstance(b, (list, tuple)) or len(b) != 3:
        v.fail("base", f"expected [lat, lon, alt] or {{lat, lon, alt}}, got {data['base']!r}")
    kw["base"] = (v.number("base.lat", b[0], lo=-90, hi=90),
                  v.number("base.lon", b[1], lo=-180, hi=180),
                  v.number("base.alt", b[2], lo=-1000, hi=20000))
    kw["n_uavs"] = v.integer("n_uavs", data["n_uavs"], lo=1)
    if kw["n_uavs"] > MAX_UAVS:
        v.fail("n_uavs", f"{kw['n_uavs']} UAVs, at most {MAX_UAVS} (every UAV adds three components to the SSP, "
                         "about 34 kB: 256 UAVs are a 9 MB archive; a typo's 100000 would build for minutes)")
    kw["strategy"] = v.choice("strategy", data["strategy"], STRATEGIES)
    t = data["targets"]
    if not isinstance(t, list) or not t:
        v.fail("targets", "expected a non-empty list of [lat, lon]")
    if len(t) > MAX_TARGETS:
        v.fail("targets", f"{len(t)} targets, at most {MAX_TARGETS} {_FMU_LIMIT}")
    kw["targets"] = [v.latlon(f"targets[{k}]", p) for k, p in enumerate(t)]
    if "takeoff_altitude" in data:
        kw["takeoff_altitude"] = v.number("takeoff_altitude", data["takeoff_altitude"],
                                          lo=0, lo_open=True, hi=1000)
    if "assignment" in data:
        kw["assignment"] = v.choice("assignment", data["assignment"], ASSIGNMENTS)
    if "zones" in data:
        zs = data["zones"]
        if zs is None:
            zs = []
        if not isinstance(zs, list):
            v.fail("zones", "expected a list of {name, polygon}")
        if len(zs) > MAX_ZONES:
            v.fail("zones", f"{len(zs)} zones, at most {MAX_ZONES} {_FMU_LIMIT}")
        zones = []
        for zi, z in enumerate(zs):
            z = v.mapping(f"zones[{zi}]", z)
            v.no_unknown(f"zones[{zi}]", z, ("name", "polygon"))
            if "polygon" not in z:
                v.fail(f"zones[{zi}].polygon", "missing required field")
            name = v.text(f"zones[{zi}].name", z.get("name", f"zone{zi + 1}"))
            poly = z["polygon"]
            if not isinstance(poly, list) or len(poly) < 3:
                v.fail(f"zones[{zi}].polygon", "expected a list of at least 3 [lat, lon] vertices")
            if len(poly) > MAX_ZONE_VERTICES:
                v.fail(f"zones[{zi}].polygon", f"{len(poly)} vertices, at most {MAX_ZONE_VERTICES} {_FMU_LIMIT}")
            zones.append({"name": name,
                          "polygon": [v.latlon(f"zones[{zi}].polygon[{k}]", p)
                                      for k, p in enumerate(poly)]})
        kw["zones"] = zones
    if "wind" in data:
        w = v.mapping("wind", data["wind"])
        v.no_unknown("wind", w, _WIND_FIELDS)
        wk: dict[str, Any] = {}
        if "probability" in w:
            wk["probability"] = v.number("wind.probability", w["probability"], lo=0, hi=1)
        if "intensities" in w:
            wi = v.mapping("wind.intensities", w["intensities"])
            v.no_unknown("wind.intensities", wi, WIND_LEVELS)
            inten = _default_intensities()
            for lvl in WIND_LEVELS:
                if lvl in wi:
                    inten[lvl] = v.number(f"wind.intensities.{lvl}", wi[lvl], lo=0, hi=50)
            if not inten["weak"] <= inten["moderate"] <= inten["strong"]:
                v.fail("wind.intensities", "speeds must satisfy weak <= moderate <= strong, "
                                           f"got {inten['weak']:g}, {inten['moderate']:g}, {inten['strong']:g}")
            wk["intensities"] = inten
        if "direction_deg" in w:
            wk["direction_deg"] = v.number("wind.direction_deg", w["direction_deg"], lo=0, hi=360,
                                           hi_open=True)
        if "decision_interval" in w:
            wk["decision_interval"] = v.number("wind.decision_interval", w["decision_interval"],
                                               lo=0, lo_open=True)
        for k in ("turbulence", "gusts", "shared"):
            if k in w:
                wk[k] = v.boolean(f"wind.{k}", w[k])
        if "effect" in w:
            wk["effect"] = v.choice("wind.effect", w["effect"], WIND_EFFECTS)
        kw["wind"] = WindConfig(**wk)
    if "seed" in data:
        kw["seed"] = v.integer("seed", data["seed"], lo=0)
    if "step" in data:
        kw["step"] = v.number("step", data["step"], lo=0, lo_open=True)
    if "stop_time" in data:
        kw["stop_time"] = v.number("stop_time", data["stop_time"], lo=0, lo_open=True)
    if "impact_diameter" in data:
        kw["impact_diameter"] = v.number("impact_diameter", data["impact_diameter"], lo=0, lo_open=True)
    if "lookahead" in data:
        kw["lookahead"] = v.number("lookahead", data["lookahead"], lo=0)
    if "algorithm" in data:
        from master.algorithms import ALGORITHMS as REGISTERED      # any algorithm the engine knows
        kw["algorithm"] = v.choice("algorithm", data["algorithm"], REGISTERED.names())
    if "algorithm_options" in data:
        kw["algorithm_options"] = _algorithm_options(v, data["algorithm_options"])
    if "end_when_all_landed" in data:
        kw["end_when_all_landed"] = v.boolean("end_when_all_landed", data["end_when_all_landed"])
    _rule_fields(v, data, kw)
    if "vehicle" in data:
        veh = data["vehicle"]
        if isinstance(veh, list):
            kw["vehicle"] = [v.choice(f"vehicle[{k}]", x, VEHICLES) for k, x in enumerate(veh)]
            if len(veh) != kw["n_uavs"]:
                v.fail("vehicle", f"one entry per UAV expected ({kw['n_uavs']}), got {len(veh)}")
        else:
            kw["vehicle"] = v.choice("vehicle", veh, VEHICLES)
    if "sitl" in data:
        so = v.mapping("sitl", data["sitl"])
        v.no_unknown("sitl", so, [f.name for f in fields(SitlOptions)])
        sk: dict[str, Any] = {}
        if "coupling" in so:
            sk["coupling"] = v.choice("sitl.coupling", so["coupling"], COUPLINGS)
        if "frame" in so:
            sk["frame"] = v.choice("sitl.frame", so["frame"], FRAMES)
        if "speedup" in so:
            sk["speedup"] = v.number("sitl.speedup", so["speedup"], lo=1)
        if "params" in so:
            pm = v.mapping("sitl.params", so["params"] or {})
            sk["params"] = {}
            for name, val in pm.items():
                if not isinstance(name, str) or not name.replace("_", "").isalnum() or len(name) > 16:
                    v.fail(f"sitl.params.{name}", "expected a firmware parameter name (A-Z, 0-9, _; at most 16)")
                sk["params"][name.upper()] = v.number(f"sitl.params.{name}", val)
        for k in ("binary", "defaults"):
            if k in so:
                if not isinstance(so[k], str):
                    v.fail(f"sitl.{k}", f"expected a path, got {so[k]!r}")
                sk[k] = so[k].strip()
        if "frame_rate" in so:
            sk["frame_rate"] = v.integer("sitl.frame_rate", so["frame_rate"], lo=0)
        if "gcs_port" in so:
            sk["gcs_port"] = v.boolean("sitl.gcs_port", so["gcs_port"])
        kw["sitl"] = SitlOptions(**sk)
    if "comm" in data:
        kw["comm"] = _comm(v, data["comm"])
    scn = UavScenario(**kw)
    if scn.strategy == "C" and scn.n_uavs > MAX_COMM_FLEET:
        v.fail("n_uavs", f"{scn.n_uavs} UAVs with strategy C, at most {MAX_COMM_FLEET} (the channel FMU's capacity)")
    if scn.stop_time < scn.step:
        v.fail("stop_time", f"must be >= step ({scn.step:g}), got {scn.stop_time:g}")
    if scn.wind.decision_interval < scn.step:
        v.fail("wind.decision_interval", f"must be >= step ({scn.step:g}), got {scn.wind.decision_interval:g}")
    _check_geometry(v, scn, {
        "target": lambda k: f"targets[{k}]",
        "zone": lambda k: f"zones[{k}].polygon",
        "zone_name": lambda k: f"zones[{k}].name",
    })
    return scn


#: the channel FMU's capacity (uavsim/channel.py MAX_FLEET, MAX_K)
MAX_COMM_FLEET, MAX_COMM_K = 64, 4


def _comm(v: _V, given) -> CommConfig:
    c = v.mapping("comm", given)
    v.no_unknown("comm", c, [f.name for f in fields(CommConfig)])
    ck: dict[str, Any] = {}
    if "mode" in c:
        ck["mode"] = v.choice("comm.mode", c["mode"], COMM_MODES)
    for name, lo, hi, lo_open in (("range", 0.0, MAX_RANGE_M * 4, False), ("period", 0.0, 3600.0, True),
                                  ("latency", 0.0, 3600.0, False), ("loss", 0.0, 1.0, False),
                                  ("near_miss", 0.0, 1000.0, True)):
        if name in c:
            ck[name] = v.number(f"comm.{name}", c[name], lo=lo, hi=hi, lo_open=lo_open)
    if "k" in c:
        ck["k"] = v.integer("comm.k", c["k"], lo=1)
        if ck["k"] > MAX_COMM_K:
            v.fail("comm.k", f"must be <= {MAX_COMM_K} (the message slots of the strategy FMU), got {ck['k']}")
    if "los" in c:
        ck["los"] = v.boolean("comm.los", c["los"])
    if c.get("links_at") is not None:
        ck["links_at"] = v.number("comm.links_at", c["links_at"], lo=0.0, hi=1e9, lo_open=False)
    return CommConfig(**ck)


def load_scenario_yaml(path) -> UavScenario:
    """Load and validate a YAML scenario file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"cannot read: {exc.strerror or exc}", file=str(path), element="file")
    try:
        data = yamlio.load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "yaml"
        raise ScenarioError(f"invalid YAML: {getattr(exc, 'problem', None) or exc}",
                            file=str(path), element=where)
    return scenario_from_dict(data, path)


def _algorithm_options(v, given) -> dict:
    from master.algorithm_options import ALGORITHM_OPTIONS
    from master.errors import CosimError
    if not isinstance(given, dict):
        v.fail("algorithm_options", f"expected a mapping of {', '.join(ALGORITHM_OPTIONS)}")
    out = {}
    for name, raw in given.items():
        if name not in ALGORITHM_OPTIONS:
            v.fail(f"algorithm_options.{name}", f"unknown algorithm setting (expected one of "
                                                f"{', '.join(ALGORITHM_OPTIONS)})")
        try:
            out[name] = ALGORITHM_OPTIONS[name].parse(raw, name)
        except CosimError as exc:
            v.fail(f"algorithm_options.{name}", exc.reason)
    return out


def scenario_to_dict(scn: UavScenario) -> dict:
    """Plain-data form of a scenario (the YAML schema)."""
    return {
        "name": scn.name,
        "base": {"lat": scn.base[0], "lon": scn.base[1], "alt": scn.base[2]},
        "takeoff_altitude": scn.takeoff_altitude,
        "n_uavs": scn.n_uavs,
        "strategy": scn.strategy,
        "assignment": scn.assignment,
        "targets": [[lat, lon] for lat, lon in scn.targets],
        "zones": [{"name": z["name"], "polygon": [[a, b] for a, b in z["polygon"]]} for z in scn.zones],
        "wind": {"probability": scn.wind.probability, "intensities": dict(scn.wind.intensities),
                 "direction_deg": scn.wind.direction_deg,
                 "decision_interval": scn.wind.decision_interval,
                 "turbulence": scn.wind.turbulence, "gusts": scn.wind.gusts,
                 "shared": scn.wind.shared, "effect": scn.wind.effect},
        "seed": scn.seed, "step": scn.step, "stop_time": scn.stop_time,
        "impact_diameter": scn.impact_diameter, "lookahead": scn.lookahead,
        "algorithm": scn.algorithm, "end_when_all_landed": scn.end_when_all_landed,
        "zone_planning": scn.zone_planning,
        **({"algorithm_options": dict(scn.algorithm_options)} if scn.algorithm_options else {}),
        "rules": scn.rules, "cruise_speed": scn.cruise_speed, "max_accel": scn.max_accel,
        "layout": scn.layout, "layout_seed": scn.layout_seed, "area_scale": scn.area_scale,
        "takeoff": scn.takeoff, "takeoff_interval": scn.takeoff_interval,
        "battery_capacity": scn.battery_capacity,
        "vehicle": list(scn.vehicle) if isinstance(scn.vehicle, list) else scn.vehicle,
        "sitl": {"coupling": scn.sitl.coupling, "frame": scn.sitl.frame, "speedup": scn.sitl.speedup,
                 "params": dict(scn.sitl.params), "binary": scn.sitl.binary, "defaults": scn.sitl.defaults,
                 "frame_rate": scn.sitl.frame_rate, "gcs_port": scn.sitl.gcs_port},
        "comm": {f.name: getattr(scn.comm, f.name) for f in fields(CommConfig)
                 if getattr(scn.comm, f.name) is not None},
    }


def dump_scenario_yaml(scn: UavScenario, path, header: str = "") -> None:
    """Write a scenario as YAML (round-trips exactly through ``load_scenario_yaml``)."""
    class _Flow(list):
        pass

    class _Dumper(yaml.SafeDumper):
        pass

    _Dumper.add_representer(_Flow, lambda d, x: d.represent_sequence(
        "tag:yaml.org,2002:seq", x, flow_style=True))
    data = scenario_to_dict(scn)
    data["targets"] = [_Flow(p) for p in data["targets"]]
    for z in data["zones"]:
        z["polygon"] = [_Flow(p) for p in z["polygon"]]
    text = yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False)
    if header:
        text = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines()) + text
    Path(path).write_text(text, encoding="utf-8")


# ===================================================== paper configuration
#: init.properties key -> (scenario field, kind)
PAPER_KEYS: dict[str, tuple[str, str]] = {
    "name": ("name", "str"),
    "base.latitude": ("base.lat", "float"),
    "base.longitude": ("base.lon", "float"),
    "base.altitude": ("base.alt", "float"),
    "takeoff.altitude": ("takeoff_altitude", "float"),
    "uav.count": ("n_uavs", "int"),
    "strategy": ("strategy", "str"),
    "assignment": ("assignment", "str"),
    "wind.probability": ("wind.probability", "float"),
    "wind.weak": ("wind.intensities.weak", "float"),
    "wind.moderate": ("wind.intensities.moderate", "float"),
    "wind.strong": ("wind.intensities.strong", "float"),
    "wind.direction": ("wind.direction_deg", "float"),
    "wind.decision_interval": ("wind.decision_interval", "float"),
    "wind.turbulence": ("wind.turbulence", "bool"),
    "wind.gusts": ("wind.gusts", "bool"),
    "seed": ("seed", "int"),
    "simulation.step": ("step", "float"),
    "simulation.stop_time": ("stop_time", "float"),
    "collision.impact_diameter": ("impact_diameter", "float"),
    "restricted.lookahead": ("lookahead", "float"),
    "restricted.zone_planning": ("zone_planning", "bool"),
    "rules": ("rules", "str"),
    "uav.cruise_speed": ("cruise_speed", "float"),
    "uav.max_accel": ("max_accel", "float"),
    "uav.battery_capacity": ("battery_capacity", "float"),
    "wind.shared": ("wind.shared", "bool"),
    "wind.effect": ("wind.effect", "str"),
    "takeoff": ("takeoff", "str"),
    "takeoff.interval": ("takeoff_interval", "float"),
    "master.algorithm": ("algorithm", "str"),
}
#: the landing point (first line of targets.txt) may differ from the base by this much
LANDING_TOLERANCE_M = 5.0


def _read_lines(path: Path):
    """(line number, stripped content) of non-blank, non-comment lines."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"cannot read: {exc.strerror or exc}", file=str(path), element="file")
    for no, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip() if not raw.lstrip().startswith("!") else ""
        if line:
            yield no, line


def _parse_float(v: _V, fld: str, s: str) -> float:
    try:
        x = float(s)
    except ValueError:
        v.fail(fld, f"expected a number, got {s!r}")
    if not math.isfinite(x):
        v.fail(fld, f"must be finite, got {s!r}")
    return x


def _parse_latlon(v: _V, fld: str, s: str) -> tuple[float, float]:
    parts = [p.strip() for p in s.split(",")]
    if len(parts) != 2:
        v.fail(fld, f"expected 'lat,lon', got {s!r}")
    lat = _parse_float(v, fld, parts[0])
    lon = _parse_float(v, fld, parts[1])
    if not -90 <= lat <= 90:
        v.fail(fld, f"latitude must be in [-90, 90], got {lat:g}")
    if not -180 <= lon <= 180:
        v.fail(fld, f"longitude must be in [-180, 180], got {lon:g}")
    return lat, lon


def load_paper_config(folder) -> UavScenario:
    """Import the paper's configuration folder (init.properties, targets.txt,
    optional restrictedAreas.txt); see docs/paper_config_format.md."""
    folder = Path(folder)
    props_path = folder / "init.properties"
    vp = _V(props_path)
    props: dict[str, str] = {}
    for no, line in _read_lines(props_path):
        sep = min((i for i in (line.find("="), line.find(":")) if i >= 0), default=-1)
        if sep <= 0:
            vp.fail(f"line {no}", f"expected 'key=value', got {line!r}")
        key, val = line[:sep].strip(), line[sep + 1:].strip()
        if key not in PAPER_KEYS:
            vp.fail(key, f"unknown key (line {no}); known keys: {', '.join(PAPER_KEYS)}")
        if key in props:
            vp.fail(key, f"duplicate key (line {no})")
        props[key] = val

    data: dict[str, Any] = {"name": folder.resolve().name}
    for key, val in props.items():
        target, kind = PAPER_KEYS[key]
        if kind == "float":
            x: Any = _parse_float(vp, key, val)
        elif kind == "int":
            try:
                x = int(val)
            except ValueError:
                vp.fail(key, f"expected an integer, got {val!r}")
        elif kind == "bool":
            if val.lower() not in ("true", "false"):
                vp.fail(key, f"expected true or false, got {val!r}")
            x = val.lower() == "true"
        else:
            x = val
        d = data
        *parents, leaf = target.split(".")
        for p in parents:
            d = d.setdefault(p, {})
        d[leaf] = x

    tpath = folder / "targets.txt"
    vt = _V(tpath)
    pts = [(no, _parse_latlon(vt, f"line {no}", line)) for no, line in _read_lines(tpath)]
    if len(pts) < 2:
        vt.fail("file", "needs the landing point (first line) and at least one target")
    (_, landing), targets = pts[0], pts[1:]
    base = data.setdefault("base", {})
    if "lat" in base or "lon" in base:
        if "lat" not in base or "lon" not in base:
            vp.fail("base.latitude" if "lat" not in base else "base.longitude",
                    "missing (both base.latitude and base.longitude, or neither)")
        e, n, _ = enu_from_geodetic(landing[0], landing[1], 0.0, base["lat"], base["lon"], 0.0)
        dist = float(np.hypot(e, n))
        if dist > LANDING_TOLERANCE_M:
            vt.fail(f"line {pts[0][0]}", f"landing point is {dist:.1f} m from the base of "
                    f"init.properties (max {LANDING_TOLERANCE_M:g} m; UAVs start and land at the base)")
    else:
        base["lat"], base["lon"] = landing
    data["targets"] = [list(p) for _, p in targets]
    target_lines = [no for no, _ in targets]
    zone_lines: list[int] = []

    zpath = folder / "restrictedAreas.txt"
    if zpath.exists():
        vz = _V(zpath)
        zones = []
        zone_lines = []
        for no, line in _read_lines(zpath):
            zone_lines.append(no)
            name = f"zone{len(zones) + 1}"
            if ":" in line:
                name, line = (s.strip() for s in line.split(":", 1))
                if not name:
                    vz.fail(f"line {no}", "empty zone name before ':'")
            verts = [s for s in (p.strip() for p in line.split(";")) if s]
            if len(verts) < 3:
                vz.fail(f"line {no}", f"polygon needs at least 3 'lat,lon' vertices, got {len(verts)}")
            zones.append({"name": name,
                          "polygon": [list(_parse_latlon(vz, f"line {no}", s)) for s in verts]})
        data["zones"] = zones

    # field-level validation reported against init.properties keys
    try:
        return scenario_from_dict(data, props_path)
    except ScenarioError as exc:
        fld = exc.element or ""
        rev = {v_[0]: k for k, v_ in PAPER_KEYS.items()}
        if fld in rev:
            exc.element = rev[fld]
        elif fld.startswith("wind.intensities"):
            exc.element = "wind.weak/moderate/strong"
        elif fld.startswith(("targets[", "zones[")):
            k = int(fld.split("[", 1)[1].split("]", 1)[0])
            if fld.startswith("targets["):
                exc.file, exc.element = str(tpath), f"line {target_lines[k]}"
            else:
                exc.file, exc.element = str(zpath), f"line {zone_lines[k]}"
        exc.args = (str(exc),)
        raise exc
