"""The UAV monitor's step: the reference, as docs/uav_monitor.md ("What it does after each master step") tells it.

After every master step [t0, t1] the monitor (``uavstudy.monitor.UavMonitor``) hands the step to
``ReferenceStep.after_step``, which

1. reads the positions and phases at t1 (those at t0 are the state the previous step left, ``FleetState``);
   motion within the step is taken as linear; a removed UAV stays where it was taken out;
2. records mission-state changes and new photos at t0 (the strategy decided them on its inputs at t0);
3. checks the *checked* UAVs -- not removed, in phase 1-3 (takeoff, fly, land) at t0 or t1, higher than the
   altitude threshold at t0 or t1 -- for UAV-UAV contacts (swept spheres of the impact diameter,
   ``CollisionDetector``) and zone incursions (``ZoneDetector``);
4. handles what it found in time order (``UavMonitor.remove_hits``: events, removal of the UAVs);
5. adds the step's 3D and horizontal path length and airborne time, each up to the removal of a UAV
   removed within the step.

Everything here is the fleet as numpy vectors, one row per UAV, every step in full.  Faster ways to compute
the very same bits (skipping idle steps, the few-UAV step on Python floats with its skip bounds, the C step)
are accelerators (``uavstudy.monitor_accel``); they read and write the state below, nothing else of this
module, and the accelerator harness checks them against this step on generated fleets.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .names import AIRBORNE_PHASES, FINAL_STATES, PHASE_LANDED

#: s of simulated time between two samples of the map track (``UavMonitor.add_track_point``): the track behind
#: map.png is thinned so that its memory stays bounded for long missions and large fleets
TRACK_INTERVAL = 0.5


def airborne(phase: np.ndarray) -> np.ndarray:
    """Phase 1 (takeoff), 2 (fly) or 3 (land), per UAV."""
    return (phase >= AIRBORNE_PHASES[0]) & (phase <= AIRBORNE_PHASES[-1])


@dataclass
class FleetState:
    """What one step leaves for the next, one row per UAV (annotation order).

    An accelerator that keeps its own copy of these values writes them back here (its ``sync``) before
    anything else reads them."""
    position: np.ndarray            # (n, 3) ENU m at the end of the last step (t0 of the next)
    phase: np.ndarray               # (n,) phase codes then, as floats
    removed: np.ndarray             # (n,) bool: taken out of the simulation
    removed_position: np.ndarray    # (n, 3) where each removed UAV was taken out (rows of the others unused)
    distance: np.ndarray            # (n,) 3D path length flown, m
    distance_xy: np.ndarray         # (n,) horizontal path length flown, m
    flight_time: np.ndarray         # (n,) s spent in phases 1-3
    took_off: np.ndarray            # (n,) bool: has been in phases 1-3 before any removal

    @classmethod
    def start(cls, position: np.ndarray, phase: np.ndarray) -> FleetState:
        n = len(position)
        return cls(position=position, phase=phase, removed=np.zeros(n, dtype=bool),
                   removed_position=np.zeros((n, 3)), distance=np.zeros(n), distance_xy=np.zeros(n),
                   flight_time=np.zeros(n), took_off=np.zeros(n, dtype=bool))


def fleet_done(phase, removed, took_off, mission_state) -> bool:
    """Has every UAV landed after flying (and has its strategy registered the landing: landed_base /
    landed_away), or been removed?  A UAV that never took off keeps the run going (it may still be waiting
    for its turn)."""
    on_ground = np.asarray(phase) == PHASE_LANDED
    removed = np.asarray(removed, dtype=bool)
    if not (on_ground | removed).all():
        return False
    landed = on_ground & np.asarray(took_off, dtype=bool)
    if mission_state is not None:
        landed &= np.isin(np.asarray(mission_state, dtype=float), FINAL_STATES)
    return bool((removed | landed).all())


class ReferenceStep:
    """The monitor's step, every step in full (module doc).  ``monitor`` is the ``UavMonitor``: this step
    uses its readings (``read_positions``, ``read_phases``), its handling of events and removals
    (``record_mission_and_photos``, ``remove_hits``), its track and its state ``monitor.fleet``."""

    def __init__(self, monitor):
        self.monitor = monitor

    def after_step(self, t0: float, t1: float) -> None:
        mon = self.monitor
        mon.gather()
        self.advance(t0, t1, mon.read_positions(), mon.read_phases())

    def advance(self, t0: float, t1: float, p1: np.ndarray, phase1: np.ndarray) -> dict:
        """The step on the positions ``p1`` and phases ``phase1`` read at t1; returns {UAV: fraction of the
        step flown before its removal} for the UAVs removed in it."""
        mon, fleet = self.monitor, self.monitor.fleet
        p0 = fleet.position
        if mon.removed_rows.size:                 # the master keeps a removed UAV's outputs; we keep its place
            p1[mon.removed_rows] = fleet.removed_position[mon.removed_rows]
        mon.record_mission_and_photos(t0, p0)

        alive = ~fleet.removed                    # at the start of the step (a new array: removals come later)
        flying = airborne(fleet.phase) | airborne(phase1)
        high = np.maximum(p0[:, 2], p1[:, 2]) > mon.cfg.altitude_threshold
        checked = alive & flying & high
        n_checked = int(np.count_nonzero(checked))
        found = []
        if n_checked >= 2:
            for c in mon.collider.check(t0, t1, p0, p1, checked):
                found.append((c.time, 0, c.i, c.j, c))
        if mon.zone_detector is not None and n_checked:
            for z in mon.zone_detector.check(t0, t1, p0, p1, checked):
                found.append((z.time, 1, z.vehicle, z.zone, z))
        cut = mon.remove_hits(found, t0, t1) if found else {}

        # path length and airborne time of the step, up to the removal of a UAV removed within it
        dt = t1 - t0
        share = alive.astype(float)
        for k, f in cut.items():
            share[k] = f
        seg = p1 - p0
        sq = seg * seg
        sxy = sq[:, 0] + sq[:, 1]
        fleet.distance += share * np.sqrt(sxy + sq[:, 2])
        fleet.distance_xy += share * np.sqrt(sxy)
        fleet.flight_time += share * dt * flying
        fleet.took_off |= alive & flying
        for k, f in cut.items():                  # a removed UAV's last position is where it was taken out
            p1[k] = p0[k] + f * seg[k]
        fleet.position, fleet.phase = p1, phase1
        mon.last_time = float(t1)
        mon.add_track_point(t1, p1, phase1, force=bool(cut))
        if mon.cfg.end_when_done and fleet_done(phase1, fleet.removed, fleet.took_off, mon.mission_state):
            mon.ctx.request_stop("every UAV has landed or been removed")
        return cut

    def sync(self) -> None:
        """Nothing to write back: this step works on ``monitor.fleet`` itself."""
