"""The UAV monitor's step made fast: the bits of the reference (``uavstudy.monitor_step``) in less time.

The monitor runs after every master step, so for a few UAVs its fixed costs (numpy calls on tiny arrays, the
swept checks) would be more than the FMUs'.  ``AcceleratedStep`` computes exactly what ``ReferenceStep`` does,
with three shortcuts, each taken only where it provably changes no bit (docs/uav_monitor.md, "Cost per step"):

- **Idle steps.**  When no value the step reads changed since the previous step (compared as bytes) and no UAV
  would be checked then (none alive in phases 1-3 above the altitude threshold, or one and no zones), the
  reference's step adds +0.0 to every sum but the airborne time: such a step adds dt to the airborne time of
  the UAVs in phases 1-3 and extends the track, nothing else.  The ground time before take-off and after
  landing costs a few microseconds per step.
- **Few UAVs** (up to ``FEW_UAVS``) run the step on Python floats: the same IEEE operations in the same order
  as the reference's vectors, without ~30 numpy calls.  The contact and zone checks are skipped in the steps
  in which no UAV can have come within reach of another or of a zone since the last exact check: clearance
  at a reference position minus the distance travelled since (the bound and its rounding margins:
  ``uavstudy/geometry.py``, "Skipping steps"); the zone check first drops every UAV whose swept segment's
  bounding box misses every zone's (``ZoneDetector.may_enter``).
- **The C step** (``uavstudy.monitor_native``, few UAVs): one call does a step in which nothing is found and
  no phase, mission state or photo count changed -- nearly every step of a mission -- on a copy of this
  step's state (``FewUavState``, copied through its declared fields); any other step it leaves to Python.

Large fleets run the reference's own vector step, plus the idle steps.  Everything here is switched off by
``COSIM_MASTER_PURE_PYTHON=1`` (``master.accel``); the accelerator harness checks each against the reference.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from master import accel

from .geometry import SKIP_MARGIN, SKIP_REL, pair_clearances
from .monitor_native import MS_DONE, MS_IDLE, NativeStep, step_function
from .monitor_step import TRACK_INTERVAL, ReferenceStep, airborne, fleet_done
from .names import AIRBORNE_PHASES, PHASE_LANDED

#: up to this many UAVs the step runs on Python floats (and in C); above, on the reference's numpy vectors
FEW_UAVS = 16
#: while a skip test keeps failing (UAVs close to each other or to a zone), its clearances are refreshed on
#: the first two failures and then every this many steps: a stale clearance is a weaker, still valid bound,
#: and the refresh costs O(pairs) / O(zones)
REFRESH_EVERY = 8


@dataclass
class FewUavState:
    """The few-UAV step's state: the monitor's ``FleetState`` values as Python lists, one entry per UAV
    (``sync`` writes them back), and the skip bounds.  The C step mirrors exactly these fields."""
    position: list                      # [x, y, z] at the end of the last step
    phase: list                         # phase codes then (floats)
    removed: list                       # bool
    distance: list                      # 3D path length, m
    distance_xy: list                   # horizontal path length, m
    flight_time: list                   # s in phases 1-3
    took_off: list                      # bool
    pair_clearance: list                # [i][j]: |p_i - p_j| - D - SKIP_MARGIN at the reference positions
    pair_travel: list                   # path length of each UAV since pair_clearance was set
    zone_clearance: list                # per UAV: distance to the nearest zone box - SKIP_MARGIN at its reference
    zone_travel: list                   # path length of each UAV since its zone_clearance was set
    pair_misses: int = 0                # consecutive steps whose pair skip test failed
    zone_misses: list = field(default_factory=list)   # per UAV: consecutive failed zone skip tests

    @classmethod
    def start(cls, fleet) -> FewUavState:
        n = len(fleet.position)
        return cls(position=fleet.position.tolist(), phase=fleet.phase.tolist(), removed=fleet.removed.tolist(),
                   distance=fleet.distance.tolist(), distance_xy=fleet.distance_xy.tolist(),
                   flight_time=fleet.flight_time.tolist(), took_off=fleet.took_off.tolist(),
                   pair_clearance=[[-math.inf] * n for _ in range(n)],    # -inf: check the first step
                   pair_travel=[0.0] * n, zone_clearance=[-math.inf] * n, zone_travel=[0.0] * n,
                   zone_misses=[0] * n)


def c_step_function():
    """The C step's entry point for this interpreter, or None (switched off, no compiler)."""
    if not accel.enabled():
        return None
    return step_function()[0]


def default_step(monitor):
    """The step a monitor runs: accelerated unless ``COSIM_MASTER_PURE_PYTHON=1``."""
    if not accel.enabled():
        return ReferenceStep(monitor)
    return AcceleratedStep(monitor, c_step_function())


class AcceleratedStep:
    """``ReferenceStep`` made fast (module doc).  ``c_step``: the C step's entry point (``monitor_native``)
    or None for Python only; it is used for fleets of up to ``FEW_UAVS``."""

    def __init__(self, monitor, c_step=None):
        self.monitor = monitor
        self.reference = ReferenceStep(monitor)
        fleet = monitor.fleet
        self.few = len(fleet.position) <= FEW_UAVS
        self.state = FewUavState.start(fleet) if self.few else None
        self.key = monitor.gather()         # the bytes of the values read, to recognise an idle step
        self.idle_next = False              # the next step is idle if nothing it reads changes
        self.idle_flying: list[int] = []    # the UAVs whose airborne time an idle step extends
        self._prepare_idle(cut=False)
        self.native = None
        if self.few and c_step is not None:
            zones = monitor.zone_detector
            d = monitor.collider.impact_diameter
            self.native = NativeStep.create(
                c_step, [(monitor.ctx.buffer(t), idx, out) for t, idx, out in monitor.hot], monitor.position_view,
                phase_lo=AIRBORNE_PHASES[0], phase_hi=AIRBORNE_PHASES[-1],
                altitude_threshold=monitor.cfg.altitude_threshold, travel_scale=1.0 + SKIP_REL,
                radius=0.5 * d, pair_limit=d + SKIP_MARGIN, margin=SKIP_MARGIN, refresh_every=REFRESH_EVERY,
                zone_boxes=zones.bounds if zones is not None else np.empty((0, 4)))
        if self.native is not None:
            self.native.push(self.state, fleet, self.idle_next, self.idle_flying)
        self.ahead = False                  # the C state is newer than the Python lists (sync pulls it)
        self.track_positions = fleet.position   # the positions array idle steps put in the track

    # -- after each master step ---------------------------------------------------------------
    def after_step(self, t0: float, t1: float) -> None:
        mon = self.monitor
        native = self.native
        if native is not None:
            code = native.step(t0, t1)
            if code == MS_DONE:         # a few-UAV step that finds nothing, done in C
                self.ahead = True
                mon.last_time = float(t1)
                if mon.keeps_track and t1 - mon.track_t[-1] >= TRACK_INTERVAL - 1e-9:
                    self.track_positions = native.p0.copy()
                    mon.add_track_point(t1, self.track_positions, mon.fleet.phase, force=True)
                else:
                    self.track_positions = None
                # no fleet-done check: it would read what the last Python step's check read (phases, removals
                # and mission states are unchanged, took_off changes for flying UAVs only, which have not
                # landed), so it would answer as that one did, whose stop request, if any, stands
                return
            if code == MS_IDLE:         # the idle step, done in C (airborne time)
                self.ahead = True
                mon.last_time = float(t1)
                if mon.keeps_track and t1 - mon.track_t[-1] >= TRACK_INTERVAL - 1e-9:
                    if self.track_positions is None:       # idle steps share one array
                        self.track_positions = native.p0.copy()
                    mon.add_track_point(t1, self.track_positions, mon.fleet.phase)
                return
            # MS_PYTHON: C gathered the values and changed nothing else; never an idle step (C took those)
            if self.ahead:
                native.pull(self.state, mon.fleet)
                self.idle_next, self.idle_flying = native.idle()
                self.ahead = False
            self._python_step(t0, t1)
            native.push(self.state, mon.fleet, self.idle_next, self.idle_flying)
            self.track_positions = mon.fleet.position
            return
        key = mon.gather()
        if self.idle_next and key == self.key:
            # nothing read changed and nothing is checked: the reference would add +0.0 to everything but
            # the airborne time of the UAVs in phases 1-3
            if self.idle_flying:
                dt = t1 - t0
                if self.few:
                    flight_time = self.state.flight_time
                    for k in self.idle_flying:
                        flight_time[k] += dt
                else:
                    mon.fleet.flight_time[self.idle_flying] += dt
            mon.last_time = float(t1)
            if mon.keeps_track and t1 - mon.track_t[-1] >= TRACK_INTERVAL - 1e-9:
                mon.add_track_point(t1, mon.fleet.position, mon.fleet.phase)
            return
        self.key = key
        self._python_step(t0, t1)

    def _python_step(self, t0, t1) -> None:
        mon = self.monitor
        p1, phase1 = mon.read_positions(), mon.read_phases()
        if self.few:
            self._few_uav_step(t0, t1, p1, phase1)
        else:
            cut = self.reference.advance(t0, t1, p1, phase1)
            self._prepare_idle(bool(cut))

    def _prepare_idle(self, cut: bool) -> None:
        """Can the next step be idle if nothing it reads changes?  Yes when then no UAV would be checked
        (p1 = p0: the checked ones are the alive, airborne ones above the altitude threshold), no removal
        happened in this step (the track point of a removed UAV moves to its removal point in the next step)
        and the positions are finite (a NaN/inf position makes every distance increment NaN)."""
        mon, fleet = self.monitor, self.monitor.fleet
        flying = airborne(fleet.phase) & ~fleet.removed
        n_checked = int(np.count_nonzero(flying & (fleet.position[:, 2] > mon.cfg.altitude_threshold)))
        busy = n_checked >= 2 or (n_checked >= 1 and mon.zone_detector is not None)
        self.idle_next = not cut and not busy and bool(np.isfinite(fleet.position).all())
        self.idle_flying = np.flatnonzero(flying).tolist() if self.idle_next else []

    def _few_uav_step(self, t0, t1, p1, phase1) -> None:
        """The reference's step on Python floats, skipping the checks that provably find nothing."""
        mon, st, fleet = self.monitor, self.state, self.monitor.fleet
        p0 = fleet.position
        if mon.removed_rows.size:
            p1[mon.removed_rows] = fleet.removed_position[mon.removed_rows]
        mon.record_mission_and_photos(t0, p0)

        lo, hi = AIRBORNE_PHASES[0], AIRBORNE_PHASES[-1]
        threshold = mon.cfg.altitude_threshold
        rows0, phases0 = st.position, st.phase
        rows1 = p1.tolist()
        phases1 = phases0 if phase1 is fleet.phase else phase1.tolist()
        removed0 = st.removed[:]                 # at the start of the step (removals come later)
        n = len(removed0)
        sqrt = math.sqrt
        pair_travel, zone_travel = st.pair_travel, st.zone_travel
        # path length and airborne time as if no UAV were removed in this step (the usual case: one loop, not
        # two); a removal below redoes them from the saved values
        dt = t1 - t0
        distance, distance_xy, flight_time, took_off = st.distance, st.distance_xy, st.flight_time, st.took_off
        saved = distance[:], distance_xy[:], flight_time[:]
        flying = [False] * n
        checked = []
        flying_next, n_high_next = [], 0       # alive in phases 1-3 at t1 / of those, above the threshold
        for k, q0, q1, was, now, gone in zip(range(n), rows0, rows1, phases0, phases1, removed0):
            dx, dy, dz = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
            sxy = dx * dx + dy * dy
            length = sqrt(sxy + dz * dz)
            pair_travel[k] += length
            zone_travel[k] += length
            share = 0.0 if gone else 1.0
            distance[k] += share * length
            distance_xy[k] += share * sqrt(sxy)
            airborne_now = lo <= now <= hi
            if airborne_now or lo <= was <= hi:
                flying[k] = True
                flight_time[k] += share * dt
                if not gone:
                    took_off[k] = True
                    z0, z1 = q0[2], q1[2]
                    if (z0 > threshold or z1 > threshold) and z0 == z0 and z1 == z1:   # max(z0, z1) > thr
                        checked.append(k)
                    if airborne_now:
                        flying_next.append(k)
                        if z1 > threshold:
                            n_high_next += 1
        found = []
        travel_scale = 1.0 + SKIP_REL
        refresh_pairs = False
        if len(checked) >= 2:
            clearance = st.pair_clearance
            apart = True
            for u in range(len(checked) - 1):
                i = checked[u]
                ci, ti = clearance[i], pair_travel[i]
                for j in checked[u + 1:]:
                    if not ci[j] - (ti + pair_travel[j]) * travel_scale > 0.0:   # NaN: not provably apart
                        apart = False
                        break
                if not apart:
                    break
            if apart:
                st.pair_misses = 0
            else:
                st.pair_misses += 1
                refresh_pairs = st.pair_misses <= 2 or st.pair_misses % REFRESH_EVERY == 0
                for c in mon.collider.check_few(t0, t1, p0, p1, checked, rows0, rows1):
                    found.append((c.time, 0, c.i, c.j, c))
        zones = mon.zone_detector
        refresh_zone = []
        if zones is not None and checked:
            zone_clearance, zone_misses = st.zone_clearance, st.zone_misses
            near = []
            for k in checked:
                if zone_clearance[k] - zone_travel[k] * travel_scale > 0.0:
                    zone_misses[k] = 0
                    continue        # provably away from every zone's box
                zone_misses[k] += 1
                if zone_misses[k] <= 2 or zone_misses[k] % REFRESH_EVERY == 0:
                    refresh_zone.append(k)
                if zones.may_enter(rows0[k][0], rows0[k][1], rows1[k][0], rows1[k][1]):
                    near.append(k)
            if near:
                mask = np.zeros(n, dtype=bool)
                mask[near] = True
                for z in zones.check(t0, t1, p0, p1, mask):
                    found.append((z.time, 1, z.vehicle, z.zone, z))
        cut = mon.remove_hits(found, t0, t1) if found else {}
        for k in cut:
            st.removed[k] = True
        if cut:     # UAVs removed within the step flew a share of it: redo the sums from the saved values
            distance[:], distance_xy[:], flight_time[:] = saved
            for k in range(n):
                share = cut[k] if k in cut else (0.0 if removed0[k] else 1.0)
                q0, q1 = rows0[k], rows1[k]
                dx, dy, dz = q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]
                sxy = dx * dx + dy * dy
                distance[k] += share * sqrt(sxy + dz * dz)
                distance_xy[k] += share * sqrt(sxy)
                if flying[k]:
                    flight_time[k] += share * dt
        for k, f in cut.items():        # a removed UAV's last position is where it was taken out
            p1[k] = p0[k] + f * (p1[k] - p0[k])
            rows1[k] = p1[k].tolist()
        # new reference positions for the skip tests that failed (the travel counts from here); the exact
        # checks above ran whether or not the clearances are refreshed
        if refresh_pairs:
            st.pair_clearance = pair_clearances(rows1, mon.collider.impact_diameter)
            st.pair_travel = [0.0] * n
        for k in refresh_zone:
            st.zone_clearance[k] = zones.clearance(rows1[k][0], rows1[k][1])
            zone_travel[k] = 0.0
        fleet.position, fleet.phase = p1, phase1
        st.position, st.phase = rows1, phases1
        mon.last_time = float(t1)
        if mon.keeps_track and (cut or t1 - mon.track_t[-1] >= TRACK_INTERVAL - 1e-9):
            mon.add_track_point(t1, p1, phase1, force=bool(cut))
        # can the next step be idle (_prepare_idle, on the lists)?  without a removal in this step, removed0
        # is current
        if cut or n_high_next >= 2 or (n_high_next and zones is not None):
            self.idle_next = False
        else:
            isfinite = math.isfinite
            self.idle_next = all(isfinite(c) for row in rows1 for c in row)
            self.idle_flying = flying_next
        if mon.cfg.end_when_done and (mon.removed_rows.size or PHASE_LANDED in phases1):
            for ph, gone in zip(phases1, st.removed):      # the usual answer, without numpy
                if ph != PHASE_LANDED and not gone:
                    return
            if fleet_done(phases1, st.removed, took_off, mon.mission_state):
                mon.ctx.request_stop("every UAV has landed or been removed")

    def sync(self) -> None:
        """Write the state kept here (the C step's, the few-UAV lists) back into ``monitor.fleet``."""
        fleet = self.monitor.fleet
        if self.native is not None and self.ahead:
            self.native.pull(self.state, fleet)
            self.idle_next, self.idle_flying = self.native.idle()
            self.ahead = False
        st = self.state
        if st is not None:
            fleet.distance = np.array(st.distance, dtype=float)
            fleet.distance_xy = np.array(st.distance_xy, dtype=float)
            fleet.flight_time = np.array(st.flight_time, dtype=float)
            fleet.took_off = np.array(st.took_off, dtype=bool)
