"""The UAV monitor's accelerators, declared for the harness (``master.accel``, tests/accelerators/).

Each one replaces the reference step ``uavstudy.monitor_step.ReferenceStep`` and must give the same bits:

- ``uavstudy.monitor-step``: ``monitor_fast.AcceleratedStep`` in Python (idle steps, the few-UAV step on
  Python floats with its skip bounds, the vector step with idle steps for large fleets);
- ``uavstudy.monitor-step-c``: the same with the C step (``monitor_native``) for few UAVs, as an extension
  module; ``uavstudy.monitor-step-c-ctypes``: the same C through ctypes (the fallback without Python headers).

A case is a scripted fleet (``FleetCase``) flown through the monitor by a stand-in for the master
(``ScriptedContext``: two buffers, deactivation, events, stop requests; a removed UAV's outputs keep their
values and a stop request ends the run after its step, as in the master).  Fleets of 1-80 UAVs: near misses
whose closest approach is the impact diameter +-1 cm (and exactly the diameter), UAVs flying side by side at
the diameter, pairs approaching on one line and stopping at the diameter +-1 cm, UAVs stopping and sliding along a zone's edge at +-1 cm, random walkers, a
NaN position, take-off below the altitude threshold, a ground wait before take-off (idle steps), landings,
mission-state changes and photos, and fleets that land one by one with ``endWhenAllLanded``.  What is
compared: every event, removal and stop request, each UAV's record, the whole ``FleetState`` and the track.
"""
from __future__ import annotations

import dataclasses
import math
import random
from dataclasses import dataclass

import numpy as np
from lxml import etree

from master import accel

from .names import FINAL_STATES, MONITOR_TYPE

SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
UAV_NS = "https://cosim-master.org/ssp/uav"
D = 2.6
#: the variables of a scripted UAV (role -> variable) and which of them are Integer
ROLES = {"x": "x", "y": "y", "z": "z", "phase": "phase", "missionState": "mission_state", "consumed": "consumed",
         "soc": "soc", "photoCount": "photo_count", "lastPhotoTarget": "last_photo_target",
         "lastPhotoTime": "last_photo_time", "lastPhotoX": "last_photo_x", "lastPhotoY": "last_photo_y"}
INTEGER = {"phase", "mission_state", "photo_count", "last_photo_target"}


@dataclass
class FleetCase:
    """A scripted fleet: per step s (time h s), every UAV's values (arrays indexed [s, uav])."""
    what: str
    h: float
    position: np.ndarray        # (steps + 1, n, 3)
    phase: np.ndarray           # (steps + 1, n) int
    mission_state: np.ndarray   # (steps + 1, n) int
    photo_count: np.ndarray     # (steps + 1, n) int
    zones: list                 # [(name, [(x, y), ...])]
    end_when_done: bool
    sync_at: int                # a step after which the monitor's state is read mid-run (0: never)

    def annotation(self):
        n = self.position.shape[1]
        uavs = "".join(f'<uav:Uav name="u{k}" index="{k}" components="u{k}_dyn u{k}_strat" homeX="0" homeY="0" '
                       + " ".join(f'{r}="u{k}.{v}"' for r, v in ROLES.items()) + "/>" for k in range(n))
        zones = "".join(f'<uav:Zone name="{name}">{" ".join(f"{x!r},{y!r}" for x, y in poly)}</uav:Zone>'
                        for name, poly in self.zones)
        extra = ' endWhenAllLanded="true"' if self.end_when_done else ""
        return etree.fromstring(
            f'<ssc:Annotation xmlns:ssc="{SSC}" type="{MONITOR_TYPE}"><uav:UavMonitor xmlns:uav="{UAV_NS}" '
            f'impactDiameter="{D}" originLatitude="45.0" originLongitude="7.0"{extra}>{uavs}{zones}'
            f'</uav:UavMonitor></ssc:Annotation>')


class ScriptedContext:
    """What the monitor uses of the master's context, over a Real and an Integer buffer holding the monitored
    variables of the UAVs ``names`` (the harness's fleets and the monitor's own tests both script it)."""

    def __init__(self, names, variables=tuple(ROLES.values()), integer=INTEGER):
        self.pos = {}
        counts = {"Real": 0, "Integer": 0}
        for name in names:
            for var in variables:
                typ = "Integer" if var in integer else "Real"
                self.pos[f"{name}.{var}"] = (typ, counts[typ])
                counts[typ] += 1
        self.buf = {"Real": np.zeros(counts["Real"]), "Integer": np.zeros(counts["Integer"], dtype=np.int32)}
        self.deactivated: list[str] = []
        self.events: list[dict] = []
        self.stops: list = []
        self.step = 0

    def position(self, q):
        return self.pos[q]

    def buffer(self, typ):
        return self.buf[typ]

    def deactivate(self, comps):
        self.deactivated.extend(comps)

    def emit(self, event):
        self.events.append(event)

    def request_stop(self, reason):
        self.stops.append((self.step, reason))

    def set(self, uav, **values):
        for var, v in values.items():
            typ, k = self.pos[f"{uav}.{var}"]
            self.buf[typ][k] = v

    def load(self, case: FleetCase, s: int) -> None:
        """The FMUs' outputs at step s; a removed UAV's keep their last values."""
        real, integer = self.buf["Real"], self.buf["Integer"]
        for k in range(case.position.shape[1]):
            if f"u{k}_dyn" in self.deactivated:
                continue
            x, y, z = case.position[s, k].tolist()
            pc = int(case.photo_count[s, k])
            for var, v in (("x", x), ("y", y), ("z", z), ("consumed", 0.001 * s), ("soc", 1.0 - 0.001 * s),
                           ("last_photo_time", case.h * s - 0.25 * case.h), ("last_photo_x", x + 0.5),
                           ("last_photo_y", y - 0.5)):
                real[self.pos[f"u{k}.{var}"][1]] = v
            for var, v in (("phase", case.phase[s, k]), ("mission_state", case.mission_state[s, k]),
                           ("photo_count", pc), ("last_photo_target", (pc * 7 + k) % 11)):
                integer[self.pos[f"u{k}.{var}"][1]] = v


def fly(case: FleetCase, step_factory, expect_c: bool = False):
    """Run the monitor on ``case`` with the step ``step_factory`` makes; everything it observed."""
    from .monitor import UavMonitor
    mon = UavMonitor(case.annotation(), None, f"{case.what}.ssp")
    mon.step_factory = step_factory
    ctx = ScriptedContext([f"u{k}" for k in range(case.position.shape[1])])
    ctx.load(case, 0)
    mon.attach(ctx, 0.0)
    if expect_c and getattr(mon.step, "native", None) is None:
        raise AssertionError("the C step did not take the fleet")
    for s in range(1, case.position.shape[0]):
        ctx.step = s
        ctx.load(case, s)
        mon.after_step(s - 1, case.h * (s - 1), case.h * s)
        if s == case.sync_at:
            mon.sync()
        if ctx.stops:
            break                   # the master ends the run after the step that asked
    mon.sync()
    f = mon.fleet
    return {"events": ctx.events, "deactivated": ctx.deactivated, "stops": ctx.stops,
            "records": [dataclasses.asdict(r) for r in mon.records], "last_time": mon.last_time,
            "fleet": [f.position, f.phase, f.removed, f.removed_position, f.distance, f.distance_xy,
                      f.flight_time, f.took_off],
            "track_t": mon.track_t, "track_p": np.stack(mon.track_p), "track_phase": np.stack(mon.track_phase)}


# -- the fleets ------------------------------------------------------------------------------------
def _unit(v):
    return v / np.linalg.norm(v)


def _near_miss(g, t, centre):
    """Two straight tracks whose closest approach, between two samples, is D + gap, gap in +-1 cm or exactly
    0 (the offset then is perpendicular to the relative velocity, so it is the minimum distance)."""
    va = g.uniform(1.0, 12.0) * _unit(g.normal(size=3) * (1, 1, 0.1))
    vb = g.uniform(1.0, 12.0) * _unit(g.normal(size=3) * (1, 1, 0.1))
    if g.random() < 0.3:
        vb = -va * g.uniform(0.5, 1.5)                      # head-on: the skip bound is exact there
    w = _unit(np.cross(va - vb, g.normal(size=3)))
    gap = 0.0 if g.random() < 0.15 else g.uniform(-0.01, 0.01)
    tc = g.uniform(0.3, 0.7) * t[-1] + 0.5 * (t[1] - t[0])
    a = centre + 0.5 * (D + gap) * w
    b = centre - 0.5 * (D + gap) * w
    return a + np.outer(t - tc, va), b + np.outer(t - tc, vb)


def _head_on_stop(g, t, centre):
    """Two UAVs approaching each other on one line and stopping D + gap apart (gap in +-1 cm, or 0): along a
    line the skip bound (clearance minus travel) is exact, so a bound off by a millimetre shows here."""
    u = _unit(g.normal(size=3) * (1, 1, 0.1))
    gap = 0.0 if g.random() < 0.15 else g.uniform(-0.01, 0.01)
    stop = g.uniform(0.3, 0.7) * t[-1] + g.uniform(0.0, t[1] - t[0])
    va, vb = g.uniform(1.0, 10.0), g.uniform(0.0, 10.0)
    before = np.minimum(t - stop, 0.0)[:, None]            # negative until the stop, then 0: they hover
    return centre - 0.5 * (D + gap) * u + before * va * u, centre + 0.5 * (D + gap) * u - before * vb * u


def _side_by_side(g, t, centre):
    """Two UAVs flying in parallel exactly D apart (a contact from the start, at the boundary)."""
    v = g.uniform(1.0, 10.0) * _unit(g.normal(size=3) * (1, 1, 0))
    off = D * _unit(np.cross(v, (0.0, 0.0, 1.0)))
    a = centre + np.outer(t, v)
    return a, a + off


def _zone_skimmer(g, t, zone):
    """Flies to the zone's west edge, stops with its xy within +-1 cm of it, slides north along it and turns
    away: an incursion or not, decided at the centimetre."""
    (x0, y0), (_, y1) = zone[0], zone[2]
    gap = g.uniform(-0.01, 0.01)
    y = g.uniform(y0, y1 - 5.0)
    speed = g.uniform(2.0, 10.0)
    arrive = g.uniform(0.2, 0.4) * t[-1]
    slide = arrive + g.uniform(1.0, 5.0)
    edge = x0 - gap
    out = np.empty((len(t), 3))
    for s, ts in enumerate(t):
        if ts <= arrive:
            out[s] = (edge - speed * (arrive - ts), y, 20.0)
        elif ts <= slide:
            out[s] = (edge, y, 20.0)
        else:
            out[s] = (edge - 0.02 * (ts - slide) ** 2, y + speed * (ts - slide), 20.0)
    return out


def _walker(g, t, centre):
    steps = len(t) - 1
    walk = np.empty((steps + 1, 3))
    walk[0] = centre + (g.uniform(-30, 30), g.uniform(-30, 30), 0.0)
    h = t[1] - t[0]
    for s in range(steps):
        walk[s + 1] = walk[s] + h * g.normal(0.0, 3.0, 3) * (1, 1, 0.1)
    return walk


def encounters(rng: random.Random, sizes) -> FleetCase:
    """A fleet of tight encounters (module doc), in cells 150 m apart, with a zone among them."""
    g = np.random.default_rng(rng.getrandbits(64))
    n = rng.choice(sizes)
    h = rng.choice([0.1, 0.25, 0.5, 1.0])
    steps = rng.randint(60, 140)
    pre = rng.choice([0, 0, 5, 20])                         # steps on the ground before take-off (idle)
    t = h * np.arange(steps + 1 - pre)
    cols = math.ceil(math.sqrt(n / 2 + 1))
    cell = lambda c: np.array([150.0 * (c % cols), 150.0 * (c // cols), 20.0 + g.uniform(-1, 1)])  # noqa: E731
    zx, zy = 150.0 * cols + 50.0, g.uniform(-20.0, 20.0)
    zone = [(zx, zy), (zx + 40.0, zy), (zx + 40.0, zy + 30.0), (zx, zy + 30.0)]
    zones = [("box", zone)] if rng.random() < 0.8 else []
    tracks = []
    c = 0
    while len(tracks) < n:
        kind = rng.random()
        if n - len(tracks) >= 2 and kind < 0.4:
            tracks += list(_near_miss(g, t, cell(c)))
        elif n - len(tracks) >= 2 and kind < 0.55:
            tracks += list(_head_on_stop(g, t, cell(c)))
        elif n - len(tracks) >= 2 and kind < 0.65:
            tracks += list(_side_by_side(g, t, cell(c)))
        elif zones and kind < 0.8:
            tracks.append(_zone_skimmer(g, t, zone))
        else:
            tracks.append(_walker(g, t, cell(c)))
        c += 1
    pos = np.stack(tracks[:n], axis=1)                      # (steps + 1 - pre, n, 3)
    phase = np.full(pos.shape[:2], 2, dtype=np.int64)
    mission = np.full(pos.shape[:2], 2, dtype=np.int64)
    photos = np.zeros(pos.shape[:2], dtype=np.int64)
    m = len(t)
    for k in range(n):
        r = rng.random()
        if r < 0.2:                                         # lands (and its strategy registers it, maybe late)
            s = rng.randrange(m // 3, m)
            phase[s:, k] = 4
            pos[s:, k] = pos[s, k] * (1, 1, 0)
            mission[min(m - 1, s + rng.choice([0, 1, 3])):, k] = rng.choice(FINAL_STATES)
        elif r < 0.27:                                      # lifting off, below the altitude threshold
            phase[:, k] = 1
            pos[:, k, 2] = 0.3
        if rng.random() < 0.3:
            s = rng.randrange(1, m)
            mission[s:, k] = rng.choice([3, 4, 5, 6])
        if rng.random() < 0.3:
            s = rng.randrange(1, m)
            photos[s:, k] += 1
            photos[min(m - 1, s + 1):, k] += rng.choice([1, 2])     # two photos within a step now and then
    if rng.random() < 0.4:
        pos[rng.randrange(1, m), rng.randrange(n), rng.randrange(3)] = math.nan
    if pre:                                                 # the ground wait: on the pads, preflight
        pad = pos[0] * (1, 1, 0)
        pos = np.concatenate([np.repeat(pad[None], pre, axis=0), pos])
        phase = np.concatenate([np.zeros((pre, n), dtype=np.int64), phase])
        mission = np.concatenate([np.zeros((pre, n), dtype=np.int64), mission])
        photos = np.concatenate([np.zeros((pre, n), dtype=np.int64), photos])
    return FleetCase("encounters", h, pos, phase, mission, photos, zones, rng.random() < 0.3,
                     rng.choice([0, rng.randrange(1, steps + 1)]))


def landing_fleet(rng: random.Random, sizes) -> FleetCase:
    """endWhenAllLanded: UAVs far apart that land one by one, the strategy registering each landing with or
    after it; now and then one never takes off (the run must not stop)."""
    g = np.random.default_rng(rng.getrandbits(64))
    n = rng.choice(sizes)
    steps = 80
    land = g.integers(10, steps + 10, n)
    registered = land + g.choice([0, 1, 3], n)
    grounded = rng.randrange(n) if rng.random() < 0.2 else -1
    speed = g.uniform(1.0, 8.0, n)
    s = np.arange(steps + 1)[:, None]
    pos = np.zeros((steps + 1, n, 3))
    pos[:, :, 0] = 300.0 * np.arange(n)
    pos[:, :, 1] = speed * np.minimum(s, land)
    flying = s < land
    pos[:, :, 2] = np.where(flying, 20.0, 0.0)
    phase = np.where(flying, 2, 4)
    mission = np.where(s >= registered, FINAL_STATES[0], 2)
    if grounded >= 0:
        pos[:, grounded, 2] = 0.0
        phase[:, grounded] = 0
        mission[:, grounded] = 2
    return FleetCase("landing", 0.5, pos, phase.astype(np.int64), mission.astype(np.int64),
                     np.zeros((steps + 1, n), dtype=np.int64), [], True, 0)


def fleet_cases(rng: random.Random, count: int, sizes):
    for i in range(count):
        yield landing_fleet(rng, sizes) if i % 4 == 3 else encounters(rng, sizes)


# -- the declarations --------------------------------------------------------------------------------
ALL_SIZES = (1, 2, 3, 4, 5, 6, 8, 12, 16, 17, 24, 40, 64, 80)
FEW_SIZES = (1, 2, 3, 4, 5, 6, 8, 12, 16)       # the C step takes fleets of up to FEW_UAVS


def _reference(case: FleetCase):
    from .monitor_step import ReferenceStep
    return fly(case, ReferenceStep)


class PythonStep:
    """``monitor_fast.AcceleratedStep`` without the C step."""
    name = "uavstudy.monitor-step"
    replaces = "uavstudy.monitor_step:ReferenceStep"

    def load(self):
        if not accel.enabled():
            return None, f"{accel.ENV} is set"
        from .monitor_fast import AcceleratedStep
        return AcceleratedStep, None

    def cases(self, rng):
        return fleet_cases(rng, 12, ALL_SIZES)

    def reference(self, case):
        return _reference(case)

    def accelerated(self, impl, case):
        return fly(case, lambda mon: impl(mon, None))


class CStep:
    """``monitor_fast.AcceleratedStep`` with the C step, called as ``backend`` says."""
    replaces = "uavstudy.monitor_step:ReferenceStep"

    def __init__(self, name: str, backend: str):
        self.name, self.backend = name, backend

    def load(self):
        if not accel.enabled():
            return None, f"{accel.ENV} is set"
        from . import monitor_native
        if self.backend == "ctypes":
            return monitor_native.ctypes_step()
        module, why = monitor_native.extension()
        return (module.step, None) if module is not None else (None, why)

    def cases(self, rng):
        return fleet_cases(rng, 12 if self.backend == "extension" else 4, FEW_SIZES)

    def reference(self, case):
        return _reference(case)

    def accelerated(self, impl, case):
        from .monitor_fast import AcceleratedStep
        return fly(case, lambda mon: AcceleratedStep(mon, impl), expect_c=True)


PYTHON_STEP = PythonStep()
C_STEP = CStep("uavstudy.monitor-step-c", "extension")
C_STEP_CTYPES = CStep("uavstudy.monitor-step-c-ctypes", "ctypes")
