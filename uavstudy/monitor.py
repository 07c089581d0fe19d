"""The UAV monitor plug-in: UAV-UAV collisions, restricted-zone incursions, removal and mission events.

Switched on by the SSD annotation of type ``org.cosim-master.uav-monitor`` (format: docs/uav_monitor.md, read
by ``uavstudy.monitor_config``), found by the master through the ``cosim_master.monitors`` entry point.  This
module is the monitor's contact with the master: it reads the UAVs' values from the master's buffers, emits
events, removes UAVs (``ctx.deactivate``), keeps the per-UAV records and the map track, and at the end hands
everything to :mod:`uavstudy.outputs` (trajectory.csv, photos.csv, summary.csv, summary.json, map.png).

What happens after each master step is the step object chosen at ``attach``: the reference
(``uavstudy.monitor_step.ReferenceStep``, what the docs explain) with ``COSIM_MASTER_PURE_PYTHON=1``, else
the accelerated step (``uavstudy.monitor_fast.AcceleratedStep``, the same bits faster; declared in
``uavstudy.monitor_accel`` and checked against the reference by the accelerator harness).  Both use only
the public methods below and the state ``fleet`` (``monitor_step.FleetState``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from master.errors import ScenarioError
from master.monitors import Monitor, register

from .geodetic import to_geodetic
from .geometry import CollisionDetector, ZoneDetector
from .monitor_config import MonitorConfig, UavSpec, check_against_plan, parse_config, run_seed
from .monitor_fast import default_step
from .monitor_step import TRACK_INTERVAL, FleetState
from .names import (FORCED_LANDING_STATES, MISSION_DETAIL, MISSION_EVENTS, MONITOR_TYPE, OPTIONAL_ROLES,
                    PHOTO_ROLES, REQUIRED_ROLES, STATE_RETURN_CMD, STATE_RETURN_LOW, UAV_COLLISION,
                    ZONE_COLLISION)
from .outputs import write_outputs

__all__ = ["UavMonitor", "UavRecord", "MonitorConfig", "UavSpec", "parse_config", "run_seed", "MONITOR_TYPE",
           "TRACK_INTERVAL"]

#: the values read after every step (the rest is read only when an event needs it)
HOT_ROLES = ("xyz", "phase", "missionState", "photoCount")


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


@register(MONITOR_TYPE)
class UavMonitor(Monitor):
    #: how ``attach`` makes the step: a callable monitor -> step object, or None for the default (the
    #: accelerated step unless ``COSIM_MASTER_PURE_PYTHON=1``, then the reference).  The accelerator harness
    #: sets it to run one implementation or the other on the same fleet.
    step_factory = None

    def __init__(self, element, plan, shown_as: str):
        super().__init__(element, plan, shown_as)
        self.cfg = parse_config(element, shown_as)
        if plan is not None:
            self.cfg.seed = run_seed(plan, self.cfg.seed)
            check_against_plan(self.cfg, plan, shown_as)
        self.collider = CollisionDetector(self.cfg.impact_diameter)
        self.zone_detector = (ZoneDetector([z["polygon"] for z in self.cfg.zones], [z["name"] for z in self.cfg.zones])
                              if self.cfg.zones else None)
        self.records = [UavRecord() for _ in self.cfg.uavs]
        self.ctx = None
        self.start = None
        self.last_time = None
        self.fleet: FleetState | None = None
        self.step = None                    # the step object (attach)
        self.removed_rows = np.empty(0, dtype=np.intp)     # the removed UAVs, ascending
        self.mission_state = None           # per UAV, as last read (NaN: no missionState variable)
        self.photo_count = None
        # the track behind map.png is thinned to one sample per TRACK_INTERVAL of simulated time (plus every
        # removal), so that its memory stays bounded for long missions and large fleets
        self.track_t: list[float] = []
        self.track_p: list[np.ndarray] = []
        self.track_phase: list[np.ndarray] = []
        #: only map.png, trajectory.csv and replay.html read the track: a campaign run (products "summary") writes
        #: none of them and keeps none (set at attach)
        self.keeps_track = True

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

    def value(self, role, k) -> float | None:
        """UAV k's value of a role now (NaN if it lacks the role; None if every UAV does)."""
        typ, idx, have = self._roles.get(role, (None, None, None))
        if typ is None:
            return None
        return float(self.ctx.buffer(typ)[idx[k]]) if have[k] else math.nan

    def _setup_hot(self, ctx) -> None:
        """The values read after every step (HOT_ROLES) are gathered with ONE ``take`` per buffer type into
        ONE preallocated array, with a view per role: for a few UAVs, one numpy call per value read would cost
        more than the whole step.  Positions are interleaved x, y, z per UAV, so their view is (n, 3)."""
        n = len(self.cfg.uavs)
        parts: dict[str, list] = {}
        where = {}
        for role in HOT_ROLES:
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
        self.hot = []       # (buffer type, index array, out array): what gather() fills, what the C step reads
        out = {}
        for typ, lst in parts.items():
            idx = np.concatenate(lst).astype(np.intp)
            out[typ] = np.empty(idx.size, dtype=ctx.buffer(typ).dtype)
            self.hot.append((typ, idx, out[typ]))
        view = {r: out[t][o:o + m] for r, (t, o, m) in where.items()}
        self.position_view = view["xyz"].reshape(n, 3)
        self.phase_view = view["phase"]
        self.mission_state_view = view.get("missionState")
        self.photo_count_view = view.get("photoCount")

    def gather(self) -> list[bytes]:
        """Fill the hot arrays from the buffers; returns their bytes (to tell cheaply if anything changed)."""
        buffer = self.ctx.buffer
        key = []
        for typ, idx, out in self.hot:
            buffer(typ).take(idx, out=out, mode="clip")    # indices are valid; 'clip' avoids a buffer copy
            key.append(out.tobytes())
        return key

    def read_positions(self) -> np.ndarray:
        """The positions just gathered, as a new (n, 3) float array."""
        return self.position_view.astype(float)

    def read_phases(self) -> np.ndarray:
        """The phases just gathered, as floats: the previous array itself when they did not change (phases
        rarely change, and arrays are never modified once a step is done, so the track can share them)."""
        b = self.phase_view.tobytes()
        if b != self._phase_bytes:
            self._phase_bytes = b
            self._phases = self.phase_view.astype(float)
        return self._phases

    def attach(self, ctx, start: float) -> None:
        self.ctx = ctx
        self.keeps_track = self.products != "summary"
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
        self.gather()
        self._phase_bytes = None
        self.fleet = FleetState.start(self.read_positions(), self.read_phases())
        self.mission_state = self._role_values("missionState", self.mission_state_view)
        self.photo_count = self._role_values("photoCount", self.photo_count_view)
        self._ms_bytes = None if self.mission_state_view is None else self.mission_state_view.tobytes()
        self._pc_bytes = None if self.photo_count_view is None else self.photo_count_view.tobytes()
        self._snapshot()
        self.add_track_point(self.start, self.fleet.position, self.fleet.phase)
        self.step = (self.step_factory or default_step)(self)

    def _role_values(self, role, raw) -> np.ndarray | None:
        """The float values of a role from its hot view (what ``_read`` gives: NaN for UAVs without it)."""
        if raw is None:
            return None
        v = raw.astype(float)
        if role in self._partial:
            v[~self._roles[role][2]] = np.nan
        return v

    def add_track_point(self, t, p, ph, force=False):
        """Append to the map track, at most one sample per TRACK_INTERVAL unless ``force`` (a removal)."""
        if not self.keeps_track:
            return
        if not force and self.track_t and t - self.track_t[-1] < TRACK_INTERVAL - 1e-9:
            return
        self.track_t.append(float(t))
        self.track_p.append(p)        # position/phase arrays are never modified once a step is done: no copy
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
        rec.removed_time = float(time)
        rec.removed_reason = reason
        rec.removed_by = by
        rec.removed_pos = tuple(float(c) for c in pos)
        self.fleet.removed[k] = True
        self.fleet.removed_position[k] = rec.removed_pos
        self.removed_rows = np.flatnonzero(self.fleet.removed)
        self._snapshot(which=k)     # its outputs are frozen at these values from now on
        self.ctx.deactivate(self.cfg.uavs[k].components)

    def remove_hits(self, found, t0, t1) -> dict:
        """Contacts and incursions of one step, ``(time, 0 contact | 1 incursion, i, j | zone, hit)``, in time
        order: events and removals; a hit of a UAV removed earlier in the step is dropped.  Returns {UAV:
        fraction of the step flown before its removal}."""
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

    def record_mission_and_photos(self, t0, p0) -> None:
        """Mission-state changes and new photos of the values just gathered, at t0 (the strategy decided them
        on its inputs at t0), for the UAVs not removed; the bytes are compared first (they rarely change)."""
        removed = self.fleet.removed
        if self.mission_state_view is not None:
            b = self.mission_state_view.tobytes()
            if b != self._ms_bytes:
                self._ms_bytes = b
                ms1 = self._role_values("missionState", self.mission_state_view)
                changed = np.flatnonzero(~removed & (ms1 != self.mission_state) & ~np.isnan(ms1))
                for k in changed:
                    self._mission_event(k, t0, int(ms1[k]), p0[k], self.value("consumed", k))
                self.mission_state = ms1
        if self.photo_count_view is not None:
            b = self.photo_count_view.tobytes()
            if b != self._pc_bytes:
                self._pc_bytes = b
                pc1 = self._role_values("photoCount", self.photo_count_view)
                for k in np.flatnonzero(~removed & (pc1 > self.photo_count)):
                    self._photo(k, int(pc1[k] - self.photo_count[k]), t0, p0[k])
                self.photo_count = pc1

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
        tgt, tt, x, y = (self.value(r, k) for r in PHOTO_ROLES)
        photo = {"target": int(tgt) if tgt is not None and not math.isnan(tgt) else -1,
                 "time": round(tt if tt is not None else float(t), 9),
                 "x": x if x is not None else float(pos[0]),
                 "y": y if y is not None else float(pos[1]),
                 "z": float(pos[2])}
        if count > 1:   # more than one photo within one step: only the last one's details are known
            photo["missed_before"] = count - 1
        self.records[k].photos.append(photo)

    # -- the step -------------------------------------------------------------------------------
    def after_step(self, n: int, t0: float, t1: float) -> None:
        self.step.after_step(t0, t1)

    # -- end of the run -------------------------------------------------------------------------
    def sync(self) -> None:
        """``fleet`` made current (an accelerated step may keep its own copy) and copied into the records."""
        if self.step is None:
            return
        self.step.sync()
        fleet = self.fleet
        for k, rec in enumerate(self.records):
            rec.distance = float(fleet.distance[k])
            rec.distance_xy = float(fleet.distance_xy[k])
            rec.flight_time = float(fleet.flight_time[k])
            rec.took_off = bool(fleet.took_off[k])

    def finish(self, out_dir: Path | None, outcome: str) -> dict:
        self.sync()
        if self.ctx is not None and self.track_t and self.track_t[-1] < self.last_time:
            # the thinned track ends where the run did
            self.add_track_point(self.last_time, self.fleet.position, self.fleet.phase, force=True)
        if self.ctx is not None:
            try:
                self._snapshot()
            except Exception:   # noqa: BLE001 - buffers may be gone after a failed start
                pass
        return write_outputs(out_dir, self, outcome, self.products)
