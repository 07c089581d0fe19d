"""The UAV monitor: UAV-UAV collisions, restricted-zone incursions and mission events.

Switched on by the SSD annotation of type ``org.cosim-master.uav-monitor`` (format: docs/uav_monitor.md,
written by ``uavstudy.build``).  After every master step [t0, t1] it

1. reads the UAV positions at t1 from the master's buffers (the positions at t0 are kept from the
   previous step) and the vehicle phases;
2. checks the *checked* UAVs -- not removed, and airborne: phase 1 takeoff, 2 fly or 3 land at t0 or t1
   (not 0 preflight, not 4 landed) and higher than ``altitudeThreshold`` (default 0.5 m) above the base
   at t0 or t1 -- for UAV-UAV contacts (``CollisionDetector``: swept spheres of diameter
   ``impactDiameter``, linear motion within the step) and for zone incursions (``ZoneDetector``: 2D
   polygons of infinite height);
3. handles the contacts and incursions in time order: on a UAV-UAV contact both UAVs are removed, on a
   zone incursion the UAV is removed (the paper takes colliding UAVs out of the simulation); removal =
   ``ctx.deactivate`` of the UAV's components, whose outputs keep their last values; a contact or an
   incursion of a UAV already removed earlier in the same step is ignored;
4. emits an event (``ctx.emit``, written to events.csv) for every contact (type ``uav``), incursion
   (type ``zone``) and mission-state change of the strategy (type ``mission``: takeoff, transit,
   return_started = all targets visited, return_low = 80 % consumed, landing, forced_landing = 95 %
   consumed away from the base, landed_base, landed_away);
5. records photos (increments of the strategy's ``photo_count`` with its ``last_photo_*`` outputs),
   integrates the distance flown and the airborne time, and keeps a track of the positions.

``finish`` hands everything to :mod:`uavstudy.outputs`, which writes trajectory.csv, photos.csv,
summary.csv, summary.json and map.png into the run folder and returns the summary stored in run.json.

Cost (docs/uav_monitor.md, "Cost per step"): one ``take`` per buffer type into preallocated arrays; a step
in which nothing read changed and nothing is checked is an *idle* step (airborne time and track only);
mission states and photos are looked at only when their bytes changed; up to ``SMALL_FLEET`` UAVs the rest
of the step runs on Python floats (``_step_small``), above on numpy vectors (``_step_vector``).  Both give
the same bits as each other and as the plain vectorized algorithm.  ``_step_small`` also skips the contact
and zone checks of steps in which no UAV can have come within reach of another or of a zone since the last
exact check (clearance minus distance travelled; bound and margins in uavstudy/geometry.py), which is
nearly every step of a mission: the 4-UAV scaling mission runs the exact pair check on 36 of 2503 steps.
Such a step, in which nothing is found and no phase, mission state or photo count changed, runs in C
(``uavstudy/monitor_native.py``, ``monitor_step.c``; the Python path is its twin and fallback): the 4-UAV
scaling mission takes the Python path on 31 of its 2552 steps.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lxml import etree

from master.errors import ScenarioError
from master.monitors import Monitor, register
from master.values import parse_boolean

from .geodetic import to_geodetic
from .geometry import SKIP_MARGIN, SKIP_REL, CollisionDetector, ZoneDetector, pair_clearances
from .monitor_native import MS_DONE, MS_IDLE, native_step
from .names import (AIRBORNE_PHASES, FINAL_STATES, FORCED_LANDING_STATES, MISSION_DETAIL, MISSION_EVENTS,
                    MONITOR_TYPE, OPTIONAL_ROLES, PHASE_LANDED, PHOTO_ROLES, REQUIRED_ROLES, STATE_RETURN_CMD, STATE_RETURN_LOW,
                    UAV_COLLISION, WIND, ZONE_COLLISION)
from .outputs import write_outputs

TRACK_INTERVAL = 0.5   # s of simulated time between two samples of the map track
#: up to this many UAVs the per-step bookkeeping runs on Python floats (for a few UAVs the fixed cost of
#: ~30 numpy calls on tiny arrays is far more than the arithmetic); above, on numpy vectors
SMALL_FLEET = 16
#: while a skip test keeps failing (UAVs close to each other or to a zone), its clearances are refreshed on
#: the first two failures and then every this many steps (a stale clearance is a weaker, still valid bound)
REFRESH_EVERY = 8


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


@dataclass
class UavRecord:
    """What the monitor remembers of one UAV."""
    removed: bool = False
    removed_time: float | None = None
    removed_reason: str | None = None     # "uav_collision" | "zone_collision"
    removed_by: str | None = None         # the other UAV or the zone
    removed_pos: tuple | None = None
    distance: float = 0.0                 # 3D path length, m
    distance_xy: float = 0.0              # horizontal path length, m
    flight_time: float = 0.0              # s airborne (phases 1-3)
    took_off: bool = False
    photos: list = field(default_factory=list)
    mission_states: list = field(default_factory=list)   # (time, state)
    forced_landing: bool = False
    return_low: bool = False
    return_commanded: bool = False        # a ground station sent it home (uavstudy.mavlink)
    last: dict = field(default_factory=dict)              # role -> last value read


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


@register(MONITOR_TYPE)
class UavMonitor(Monitor):
    def __init__(self, element, plan, shown_as: str):
        super().__init__(element, plan, shown_as)
        self.cfg = parse_config(element, shown_as)
        if plan is not None:
            self.cfg.seed = run_seed(plan, self.cfg.seed)
            fmus = getattr(plan, "fmus", None)
            for u in self.cfg.uavs:
                for c in u.components:
                    if fmus is not None and c not in fmus:
                        raise ScenarioError(f"UAV {u.name}: no component {c!r}", file=shown_as,
                                            element="uav:UavMonitor")
                for role, q in u.vars.items():
                    try:
                        plan.var(q)
                    except (KeyError, ValueError, TypeError):
                        raise ScenarioError(f"UAV {u.name}: {role}={q!r} is not a variable of the system",
                                            file=shown_as, element="uav:UavMonitor") from None
        self.collider = CollisionDetector(self.cfg.impact_diameter)
        self.zone_detector = (ZoneDetector([z["polygon"] for z in self.cfg.zones], [z["name"] for z in self.cfg.zones])
                              if self.cfg.zones else None)
        self.records = [UavRecord() for _ in self.cfg.uavs]
        self.ctx = None
        self.start = None
        self.last_time = None
        # the track behind map.png is thinned to one sample per TRACK_INTERVAL of simulated time (plus every
        # removal), so that its memory stays bounded for long missions and large fleets
        self.track_t: list[float] = []
        self.track_p: list[np.ndarray] = []
        self.track_phase: list[np.ndarray] = []
        n = len(self.cfg.uavs)
        self._small = n <= SMALL_FLEET
        # per-UAV accumulators, copied into the records by sync(): Python lists of floats for small fleets
        # (the per-step loop works on Python floats), numpy vectors otherwise -- the same IEEE arithmetic
        if self._small:
            self._dist, self._dist_xy, self._ftime = [0.0] * n, [0.0] * n, [0.0] * n
            self._took_off = [False] * n
        else:
            self._dist, self._dist_xy, self._ftime = np.zeros(n), np.zeros(n), np.zeros(n)
            self._took_off = np.zeros(n, dtype=bool)
        self._removed = np.zeros(n, dtype=bool)
        self._rm_idx = np.empty(0, dtype=np.intp)     # removed UAVs and where they were taken out
        self._rm_pos = np.empty((0, 3))
        self._idle = False
        self.skip_idle = True     # False: every step takes the full path (for tests; same results)
        # small fleets: skip the contact / zone checks of steps that provably hold none (geometry module
        # doc, "Skipping steps"): clearances at a reference position and the distance travelled since
        self.precheck = True      # False: every step runs the exact checks (the reference; same results)
        # small fleets: the common step in C (uavstudy/monitor_native.py) when a compiler is at hand; False:
        # Python only (same results).  precheck, skip_idle and native are read once, at attach
        self.native = True
        self._native = None
        self._ahead = False
        self._clear = [[-math.inf] * n for _ in range(n)]   # pair clearances; -inf: check the first step
        self._trav = [0.0] * n                               # travelled since the pair clearances were set
        self._zclear = [-math.inf] * n                       # per UAV: clearance to the zones' boxes
        self._ztrav = [0.0] * n                              # travelled since its zone clearance was set
        # consecutive steps whose skip test failed (pairs; per UAV for zones): a stale clearance is still a
        # valid bound, only a weaker one, so while UAVs stay close the O(pairs) / O(zones) refresh is done
        # on the first two such steps and then every REFRESH_EVERY-th only
        self._fails = 0
        self._zfails = [0] * n
        self._reml = [False] * n                             # self._removed as a Python list

    def required_variables(self) -> list[str]:
        out, seen = [], set()
        for u in self.cfg.uavs:
            for q in u.vars.values():
                if q not in seen:
                    seen.add(q)
                    out.append(q)
        return out

    # -- reading the buffers ----------------------------------------------------------------
    def _index(self, ctx, role):
        """(type, index array, mask of UAVs having the role) for one role over all UAVs."""
        typ, idx, have = None, [], []
        for u in self.cfg.uavs:
            q = u.vars.get(role)
            if q is None:
                idx.append(0)
                have.append(False)
                continue
            t, k = ctx.position(q)
            if typ is None:
                typ = t
            elif t != typ:
                raise ScenarioError(f"{role} variables of the UAVs have different types ({typ}, {t})",
                                    file=self.shown_as, element="uav:UavMonitor")
            idx.append(k)
            have.append(True)
        return typ, np.asarray(idx, dtype=np.intp), np.asarray(have, dtype=bool)

    def _read(self, role) -> np.ndarray | None:
        typ, idx, have = self._roles.get(role, (None, None, None))
        if typ is None:
            return None
        v = np.take(self.ctx.buffer(typ), idx).astype(float)
        if not have.all():
            v[~have] = np.nan
        return v

    def _value(self, role, k) -> float | None:
        """UAV k's value of a role now, ``_read(role)[k]`` without reading the other UAVs' (NaN if it lacks the
        role; None if every UAV does)."""
        typ, idx, have = self._roles.get(role, (None, None, None))
        if typ is None:
            return None
        return float(self.ctx.buffer(typ)[idx[k]]) if have[k] else math.nan

    def _setup_hot(self, ctx) -> None:
        """Index arrays of the values read after every step (positions, phase, mission state, photo count):
        per buffer type ONE index array and ONE preallocated array that ``np.take`` fills, with views per
        role.  Positions are interleaved x, y, z per UAV, so their view is the (N, 3) position array."""
        n = len(self.cfg.uavs)
        parts: dict[str, list] = {}
        where = {}
        for role in ("xyz", "phase", "missionState", "photoCount"):
            if role == "xyz":
                typ, idx = self._xyz_type, self._xyz_idx.ravel()
            else:
                typ, idx, have = self._roles[role]
                if typ is None:
                    continue
            lst = parts.setdefault(typ, [])
            off = sum(len(a) for a in lst)
            lst.append(idx)
            where[role] = (typ, off, len(idx))
        self._hot = []
        out = {}
        for typ, lst in parts.items():
            idx = np.concatenate(lst).astype(np.intp)
            out[typ] = np.empty(idx.size, dtype=ctx.buffer(typ).dtype)
            self._hot.append((typ, idx, out[typ]))
        view = {r: out[t][o:o + m] for r, (t, o, m) in where.items()}
        self._pos_view = view["xyz"].reshape(n, 3)
        self._ph_view = view["phase"]
        self._ms_view = view.get("missionState")
        self._pc_view = view.get("photoCount")

    def _read_hot(self) -> list:
        """Fill the hot arrays from the buffers; returns their bytes (to tell cheaply if anything changed)."""
        buffer = self.ctx.buffer
        key = []
        for typ, idx, out in self._hot:
            buffer(typ).take(idx, out=out, mode="clip")    # indices are valid; 'clip' avoids a buffer copy
            key.append(out.tobytes())
        return key

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx
        self.start = self.last_time = float(start)
        self._roles = {r: self._index(ctx, r) for r in REQUIRED_ROLES + OPTIONAL_ROLES}
        self._partial = {r for r, (typ, _, have) in self._roles.items() if typ is not None and not have.all()}
        types = {self._roles[r][0] for r in ("x", "y", "z")}
        if len(types) != 1:
            raise ScenarioError("x, y and z of the UAVs must have one type", file=self.shown_as,
                                element="uav:UavMonitor")
        self._xyz_type = types.pop()
        self._xyz_idx = np.stack([self._roles[r][1] for r in ("x", "y", "z")], axis=1)
        self._setup_hot(ctx)
        self._key = self._read_hot()
        self.p0 = self._pos_view.astype(float)
        self.ph0 = self._ph_view.astype(float)
        self.ms0 = self._role_values("missionState", self._ms_view)
        self.pc0 = self._role_values("photoCount", self._pc_view)
        self._ms_bytes = None if self._ms_view is None else self._ms_view.tobytes()
        self._pc_bytes = None if self._pc_view is None else self._pc_view.tobytes()
        self._ph_bytes = self._ph_view.tobytes()     # the bytes self.ph0 was made of
        self._air0 = (self.ph0 >= AIRBORNE_PHASES[0]) & (self.ph0 <= AIRBORNE_PHASES[-1])
        self._p0l, self._ph0l = self.p0.tolist(), self.ph0.tolist()
        self._snapshot()
        self._track(self.start, self.p0, self.ph0)
        self._prepare_idle(cut=False)
        self._native = None
        if self._small and self.native and self.precheck and self.skip_idle:
            zd, d = self.zone_detector, self.collider.impact_diameter
            self._native = native_step(
                len(self.cfg.uavs), [(ctx.buffer(t), idx, out) for t, idx, out in self._hot], self._pos_view,
                lo=AIRBORNE_PHASES[0], hi=AIRBORNE_PHASES[-1], thr=self.cfg.altitude_threshold, grow=1.0 + SKIP_REL,
                radius=0.5 * d, lim=d + SKIP_MARGIN, margin=SKIP_MARGIN, refresh_every=REFRESH_EVERY,
                zone_boxes=zd._bounds_list if zd is not None else [])
        if self._native is not None:
            self._native.push(self)
        self._ahead = False         # the C state is newer than the Python lists (UavMonitor.sync pulls it)
        self._p_track = self.p0     # the positions array idle steps put in the track

    def _role_values(self, role, raw) -> np.ndarray | None:
        """The float values of a role from its hot view (what ``_read`` gives: NaN for UAVs without it)."""
        if raw is None:
            return None
        v = raw.astype(float)
        if role in self._partial:
            v[~self._roles[role][2]] = np.nan
        return v

    def _track(self, t, p, ph, force=False):
        if not force and self.track_t and t - self.track_t[-1] < TRACK_INTERVAL - 1e-9:
            return
        self.track_t.append(float(t))
        self.track_p.append(p)        # p0/p1/ph arrays are never modified once a step is done: no copy
        self.track_phase.append(ph)

    def _snapshot(self, which=None):
        if which is not None:       # one UAV (at its removal): read just its values
            for role in REQUIRED_ROLES + OPTIONAL_ROLES:
                typ, idx, have = self._roles.get(role, (None, None, None))
                if typ is not None:
                    self.records[which].last[role] = (float(self.ctx.buffer(typ)[idx[which]]) if have[which]
                                                      else math.nan)
            return
        for role in REQUIRED_ROLES + OPTIONAL_ROLES:
            v = self._read(role)
            if v is None:
                continue
            for k, rec in enumerate(self.records):
                if not rec.removed:
                    rec.last[role] = float(v[k])

    # -- events -------------------------------------------------------------------------------
    def _geo(self, p):
        lat, lon, alt = to_geodetic(self.cfg.origin, p[0], p[1], p[2])
        return float(lat), float(lon), float(alt)

    def _event(self, time, typ, event, uav, other, pos, distance=None, detail="", consumed=None):
        lat, lon, alt = self._geo(pos)
        self.ctx.emit({"time": round(float(time), 9), "type": typ, "event": event, "uav": uav, "other": other,
                       "x": float(pos[0]), "y": float(pos[1]), "z": float(pos[2]), "lat": lat, "lon": lon,
                       "alt": alt, "distance": distance, "consumed": consumed, "detail": detail})

    def _remove(self, k, time, reason, by, pos):
        rec = self.records[k]
        rec.removed = True
        self._removed[k] = True
        self._reml[k] = True
        rec.removed_time = float(time)
        rec.removed_reason = reason
        rec.removed_by = by
        rec.removed_pos = tuple(float(c) for c in pos)
        self._rm_idx = np.flatnonzero(self._removed)
        self._rm_pos = np.array([self.records[i].removed_pos for i in self._rm_idx], dtype=float).reshape(-1, 3)
        self._snapshot(which=k)     # its outputs are frozen at these values from now on
        self.ctx.deactivate(self.cfg.uavs[k].components)

    def after_step(self, n: int, t0: float, t1: float) -> None:
        nat = self._native
        if nat is not None:
            code = nat.step(t0, t1)
            if code == MS_DONE:         # a step of _step_small that finds nothing, done in C
                self._ahead = True
                self.last_time = float(t1)
                track_t = self.track_t
                if t1 - track_t[-1] >= TRACK_INTERVAL - 1e-9:      # a track point: _track's appends, inline
                    p = self._p_track = nat.p0.copy()
                    track_t.append(float(t1))
                    self.track_p.append(p)
                    self.track_phase.append(self.ph0)
                else:
                    self._p_track = None
                # no fleet-done check: it would read what the last Python step's check read (phases, removals and
                # mission states are unchanged, took_off changes for flying UAVs only, which have not landed), so
                # it would answer as that one did, whose stop request, if any, stays requested
                return
            if code == MS_IDLE:         # the idle step below, done in C (airborne time)
                self._ahead = True
                self.last_time = float(t1)
                if t1 - self.track_t[-1] >= TRACK_INTERVAL - 1e-9:
                    if self._p_track is None:       # idle steps share one array, as below
                        self._p_track = nat.p0.copy()
                    self._track(t1, self._p_track, self.ph0)
                return
            # MS_PYTHON: C gathered the hot values and changed nothing else; never an idle step (C took those)
            if self._ahead:
                nat.pull(self)
                self._ahead = False
            self._full_step(t0, t1)
            nat.push(self)
            self._p_track = self.p0
            return
        key = self._read_hot()
        if self._idle and key == self._key and self.skip_idle:
            # nothing read changed and nothing is checked: only the airborne time and the track go on (this
            # is what the full step below computes then, bit for bit: every other increment is +0.0)
            if self._idle_fly:
                dt = t1 - t0
                if self._small:
                    for k in self._idle_fly:
                        self._ftime[k] += dt
                else:
                    self._ftime[self._idle_fly] += dt
            self.last_time = float(t1)
            if t1 - self.track_t[-1] >= TRACK_INTERVAL - 1e-9:
                self._track(t1, self.p0, self.ph0)
            return
        self._key = key
        self._full_step(t0, t1)

    def _full_step(self, t0, t1) -> None:
        """A step that is not idle, on the hot values just gathered."""
        p0 = self.p0
        p1 = self._pos_view.astype(float)
        b = self._ph_view.tobytes()
        if b == self._ph_bytes:     # phases rarely change: reuse ph0 (arrays are never modified once made)
            ph1 = self.ph0
        else:
            ph1 = self._ph_view.astype(float)
            self._ph_bytes = b
        removed = self._removed                 # not yet modified in this step (_remove() comes later)
        if self._rm_idx.size:                   # a removed UAV stays where it was taken out
            p1[self._rm_idx] = self._rm_pos

        # mission events and photos first: the strategy decided them on its inputs at t0
        if self._ms_view is not None:
            b = self._ms_view.tobytes()
            if b != self._ms_bytes:
                self._ms_bytes = b
                ms1 = self._role_values("missionState", self._ms_view)
                changed = np.flatnonzero(~removed & (ms1 != self.ms0) & ~np.isnan(ms1))
                for k in changed:
                    self._mission_event(k, t0, int(ms1[k]), p0[k], self._value("consumed", k))
                self.ms0 = ms1
        if self._pc_view is not None:
            b = self._pc_view.tobytes()
            if b != self._pc_bytes:
                self._pc_bytes = b
                pc1 = self._role_values("photoCount", self._pc_view)
                for k in np.flatnonzero(~removed & (pc1 > self.pc0)):
                    self._photo(k, int(pc1[k] - self.pc0[k]), t0, p0[k])
                self.pc0 = pc1

        if self._small:
            self._step_small(t0, t1, p0, p1, ph1)
        else:
            self._step_vector(t0, t1, p0, p1, ph1)
        if self.cfg.end_when_done and (self._rm_idx.size or PHASE_LANDED in (self._ph0l if self._small else ph1)):
            self._stop_if_fleet_done(ph1)

    def _stop_if_fleet_done(self, ph1) -> None:
        """Nothing happens to a fleet that has landed or been removed for good: stop instead of idling to the
        stop time.  A UAV that never took off keeps the run going (it may still be waiting for its turn)."""
        if self._small:     # the usual answer, on Python values (a few numpy calls cost more than 4 tests)
            for ph, gone in zip(self._ph0l, self._reml):
                if ph != PHASE_LANDED and not gone:
                    return
        on_ground = ph1 == PHASE_LANDED
        if not (on_ground | self._removed).all():
            return          # a UAV neither landed nor removed: the fleet is not done (the test below is stricter)
        landed = on_ground & np.asarray(self._took_off, dtype=bool)
        if self.ms0 is not None:   # and the strategy has registered the landing (landed_base / landed_away)
            landed &= np.isin(np.asarray(self.ms0, dtype=float), FINAL_STATES)
        if (self._removed | landed).all():
            self.ctx.request_stop("every UAV has landed or been removed")

    def _step_small(self, t0, t1, p0, p1, ph1) -> None:
        """The rest of a step on Python floats (few UAVs): the same operations as ``_step_vector``, except
        that contact and zone checks that provably find nothing are skipped (``precheck``)."""
        cfg = self.cfg
        lo, hi = AIRBORNE_PHASES[0], AIRBORNE_PHASES[-1]
        thr = cfg.altitude_threshold
        p0l, ph0l = self._p0l, self._ph0l
        p1l, ph1l = p1.tolist(), (ph0l if ph1 is self.ph0 else ph1.tolist())
        rem = self._reml[:]                     # at the start of the step (a copy)
        nu = len(rem)
        sqrt = math.sqrt
        trav, ztrav = self._trav, self._ztrav
        # distance flown and airborne time of the UAVs flying this step, as if no UAV were removed in it (the
        # usual case; one loop instead of two); a removal below recomputes them from the saved values
        dt = t1 - t0
        dist, dist_xy, ftime, took_off = self._dist, self._dist_xy, self._ftime, self._took_off
        saved = dist[:], dist_xy[:], ftime[:]
        flying = [False] * nu
        checked = []
        fly_next, n_next = [], 0        # alive in phases 1-3 at t1 / and above the threshold (see below)
        for k, a, b, g0, g1, gone in zip(range(nu), p0l, p1l, ph0l, ph1l, rem):
            dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
            sxy = dx * dx + dy * dy
            step_len = sqrt(sxy + dz * dz)
            trav[k] += step_len
            ztrav[k] += step_len
            f = 0.0 if gone else 1.0
            dist[k] += f * step_len
            dist_xy[k] += f * sqrt(sxy)
            a1 = lo <= g1 <= hi
            if a1 or lo <= g0 <= hi:
                flying[k] = True
                ftime[k] += f * dt
                if not gone:
                    took_off[k] = True
                    z0, z1 = a[2], b[2]
                    if (z0 > thr or z1 > thr) and z0 == z0 and z1 == z1:   # np.maximum(z0, z1) > thr
                        checked.append(k)
                    if a1:
                        fly_next.append(k)
                        if z1 > thr:
                            n_next += 1
        found = []
        precheck = self.precheck
        grow = 1.0 + SKIP_REL
        refresh_pairs = False
        if len(checked) >= 2:
            clear = self._clear
            far = precheck
            for u in range(len(checked) - 1) if far else ():
                i = checked[u]
                ci, ti = clear[i], trav[i]
                for j in checked[u + 1:]:
                    if not ci[j] - (ti + trav[j]) * grow > 0.0:   # NaN: not provably apart
                        far = False
                        break
                if not far:
                    break
            if far:
                self._fails = 0
            else:
                self._fails += 1
                refresh_pairs = self._fails <= 2 or self._fails % REFRESH_EVERY == 0
                for c in self.collider.check_few(t0, t1, p0, p1, checked, p0l, p1l):
                    found.append((c.time, 0, c.i, c.j, c))
        zd = self.zone_detector
        refresh_zone = []
        if zd is not None and checked:
            zclear, zfails = self._zclear, self._zfails
            near = []
            for k in checked:
                if precheck and zclear[k] - ztrav[k] * grow > 0.0:
                    zfails[k] = 0
                    continue        # provably away from every zone's box
                zfails[k] += 1
                if zfails[k] <= 2 or zfails[k] % REFRESH_EVERY == 0:
                    refresh_zone.append(k)
                if zd.may_enter(p0l[k][0], p0l[k][1], p1l[k][0], p1l[k][1]):
                    near.append(k)
            if near:
                mask = np.zeros(nu, dtype=bool)
                mask[near] = True
                for z in zd.check(t0, t1, p0, p1, mask):
                    found.append((z.time, 1, z.vehicle, z.zone, z))
        cut = self._handle(found, t0, t1) if found else {}
        if cut:     # UAVs removed within the step flew a fraction f of it: redo the sums from the saved values
            dist[:], dist_xy[:], ftime[:] = saved
            for k in range(nu):
                f = cut[k] if k in cut else (0.0 if rem[k] else 1.0)
                a, b = p0l[k], p1l[k]
                dx, dy, dz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
                sxy = dx * dx + dy * dy
                dist[k] += f * sqrt(sxy + dz * dz)
                dist_xy[k] += f * sqrt(sxy)
                if flying[k]:
                    ftime[k] += f * dt
        for k, f in cut.items():        # removed UAVs: keep their position at removal in the track
            p1[k] = p0[k] + f * (p1[k] - p0[k])
            p1l[k] = p1[k].tolist()
        # new reference positions for the skip tests that failed (the travel counts from here); the exact
        # checks above ran whether or not the clearances are refreshed
        if refresh_pairs:
            self._clear = pair_clearances(p1l, self.collider.impact_diameter)
            self._trav = [0.0] * nu
        for k in refresh_zone:
            self._zclear[k] = zd.clearance(p1l[k][0], p1l[k][1])
            ztrav[k] = 0.0
        self.p0, self.ph0, self._p0l, self._ph0l = p1, ph1, p1l, ph1l
        self.last_time = float(t1)
        if cut or t1 - self.track_t[-1] >= TRACK_INTERVAL - 1e-9:
            self._track(t1, p1, ph1, force=bool(cut))
        # can the next step be idle (see _prepare_idle)?  without a removal in this step, rem is current
        if cut or n_next >= 2 or (n_next and zd is not None):
            self._idle = False
            return
        isfinite = math.isfinite
        self._idle = all(isfinite(c) for row in p1l for c in row)
        self._idle_fly = fly_next

    def _step_vector(self, t0, t1, p0, p1, ph1) -> None:
        """The rest of a step on numpy vectors (many UAVs)."""
        cfg = self.cfg
        alive = ~self._removed                  # at the start of the step (a new array)
        air0 = self._air0
        air1 = (ph1 >= AIRBORNE_PHASES[0]) & (ph1 <= AIRBORNE_PHASES[-1])
        flying = air0 | air1
        high = np.maximum(p0[:, 2], p1[:, 2]) > cfg.altitude_threshold
        checked = alive & flying & high
        nchk = int(np.count_nonzero(checked))
        found = []
        if nchk >= 2:
            for c in self.collider.check(t0, t1, p0, p1, checked):
                found.append((c.time, 0, c.i, c.j, c))
        if self.zone_detector is not None and nchk:
            for z in self.zone_detector.check(t0, t1, p0, p1, checked):
                found.append((z.time, 1, z.vehicle, z.zone, z))
        cut = self._handle(found, t0, t1) if found else {}

        # distance flown and airborne time of the UAVs flying this step (up to their removal)
        dt = t1 - t0
        frac = alive.astype(float)
        for k, f in cut.items():
            frac[k] = f
        seg = p1 - p0
        sq = seg * seg
        sxy = sq[:, 0] + sq[:, 1]
        self._dist += frac * np.sqrt(sxy + sq[:, 2])
        self._dist_xy += frac * np.sqrt(sxy)
        self._ftime += frac * dt * flying
        self._took_off |= alive & flying
        for k, f in cut.items():        # removed UAVs: keep their position at removal in the track
            p1[k] = p0[k] + f * seg[k]
        self.p0, self.ph0, self._air0 = p1, ph1, air1
        self.last_time = float(t1)
        self._track(t1, p1, ph1, force=bool(cut))
        self._prepare_idle(bool(cut))

    def _prepare_idle(self, cut: bool) -> None:
        """Can the next step take the idle path if nothing it reads changes?  Yes when then no UAV would be
        checked (p1 = p0: the checked ones are the alive, airborne ones above the altitude threshold), no
        removal happened in this step (the track point of a removed UAV moves to its removal point in the
        next step) and the positions are finite (a NaN/inf position makes every distance increment NaN).
        The idle step then adds dt to the airborne time of the alive UAVs in phases 1-3."""
        ph, z = self.ph0, self.p0[:, 2]
        air = (ph >= AIRBORNE_PHASES[0]) & (ph <= AIRBORNE_PHASES[-1]) & ~self._removed
        nchk = int(np.count_nonzero(air & (z > self.cfg.altitude_threshold)))
        busy = nchk >= 2 or (nchk >= 1 and self.zone_detector is not None)
        self._idle = not cut and not busy and bool(np.isfinite(self.p0).all())
        self._idle_fly = np.flatnonzero(air).tolist() if self._idle else []

    def _handle(self, found, t0, t1) -> dict:
        """Contacts and incursions in time order: removals and events.  Returns {UAV: fraction of the step
        flown before its removal}."""
        cfg = self.cfg
        cut = {}
        dt = t1 - t0
        for time, kind, a, b, hit in sorted(found, key=lambda e: e[:4]):
            if kind == 0:
                if a in cut or b in cut:
                    continue
                pi, pj = np.asarray(hit.pos_i), np.asarray(hit.pos_j)
                dist = float(np.linalg.norm(pi - pj))
                ua, ub = cfg.uavs[a].name, cfg.uavs[b].name
                self._event(time, "uav", "collision", ua, ub, 0.5 * (pi + pj), dist,
                            f"{ua} at ({pi[0]:.2f}, {pi[1]:.2f}, {pi[2]:.2f}), {ub} at ({pj[0]:.2f}, "
                            f"{pj[1]:.2f}, {pj[2]:.2f}); min distance {hit.min_distance:.3f} m at "
                            f"t={hit.time_min:.3f} s")
                for k, other, pos in ((a, ub, pi), (b, ua, pj)):
                    cut[k] = (time - t0) / dt if dt > 0 else 0.0
                    self._remove(k, time, UAV_COLLISION, other, pos)
            else:
                if a in cut:
                    continue
                ua = cfg.uavs[a].name
                self._event(time, "zone", "zone_incursion", ua, hit.zone_name, hit.position, None,
                            f"{ua} entered restricted zone {hit.zone_name}"
                            + ("" if hit.inside_at_end else " (cut a corner within the step)"))
                cut[a] = hit.fraction
                self._remove(a, time, ZONE_COLLISION, hit.zone_name, hit.position)
        return cut

    def _mission_event(self, k, t, state, pos, consumed):
        rec = self.records[k]
        rec.mission_states.append((float(t), state))
        if state in FORCED_LANDING_STATES:
            rec.forced_landing = True
        if state == STATE_RETURN_LOW:
            rec.return_low = True
        if state == STATE_RETURN_CMD:
            rec.return_commanded = True
        name = MISSION_EVENTS.get(state, f"state_{state}")
        self._event(t, "mission", name, self.cfg.uavs[k].name, None, pos, None,
                    MISSION_DETAIL.get(state, ""), consumed)

    def _photo(self, k, count, t, pos):
        tgt, tt, x, y = (self._value(r, k) for r in PHOTO_ROLES)
        photo = {"target": int(tgt) if tgt is not None and not math.isnan(tgt) else -1,
                 "time": round(tt if tt is not None else float(t), 9),
                 "x": x if x is not None else float(pos[0]),
                 "y": y if y is not None else float(pos[1]),
                 "z": float(pos[2])}
        if count > 1:   # more than one photo within one step: only the last one's details are known
            photo["missed_before"] = count - 1
        self.records[k].photos.append(photo)

    # -- end of the run -------------------------------------------------------------------------
    def sync(self) -> None:
        """Copy the vector accumulators (distance, flight time) into the per-UAV records (and the C step's
        state into the Python one first: ``p0`` too is current afterwards)."""
        if self._native is not None and self._ahead:
            self._native.pull(self)
            self._ahead = False
        for k, rec in enumerate(self.records):
            rec.distance = float(self._dist[k])
            rec.distance_xy = float(self._dist_xy[k])
            rec.flight_time = float(self._ftime[k])
            rec.took_off = bool(self._took_off[k])

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        self.sync()
        if self.ctx is not None and self.track_t and self.track_t[-1] < self.last_time:
            self._track(self.last_time, self.p0, self.ph0, force=True)   # the thinned track ends where the run did
        if self.ctx is not None:
            try:
                self._snapshot()
            except Exception:   # noqa: BLE001 - buffers may be gone after a failed start
                pass
        return write_outputs(out_dir, self, outcome, self.products)
