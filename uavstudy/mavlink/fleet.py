"""The fleet as a ground station sees it: one MAVLink vehicle per UAV of the UAV monitor, the values its
messages are made of (read from the master's buffers), and its plan (targets as waypoints, zones as
exclusion fences) in WGS84 about the scenario origin (``uavstudy.geodetic``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from master.errors import CosimError
from uavsim import params as P

from ..geodetic import frame, to_geodetic
from ..names import BATTERY, DYNAMICS, STRATEGY, component

#: MAVLink system ids a vehicle may have: 0 is the broadcast address, 255 the ground station's by custom
MAX_VEHICLES = 254
#: up to this many vehicles positions are converted one by one on floats (numpy's fixed cost per call is
#: more than the arithmetic of a few points), above as vectors
SMALL_FLEET = 32
#: the strategy's ground-station input (fmu_sources/UavStrategy.py)
COMMAND_INPUT = "command"

#: column -> (part, variable); a column whose variable the scenario lacks reads as NaN
COLUMNS = {
    "x": (DYNAMICS, "x"), "y": (DYNAMICS, "y"), "z": (DYNAMICS, "z"),
    "vx": (DYNAMICS, "vx"), "vy": (DYNAMICS, "vy"), "vz": (DYNAMICS, "vz"),
    "groundspeed": (DYNAMICS, "groundspeed"), "airspeed": (DYNAMICS, "airspeed"), "tilt": (DYNAMICS, "tilt"),
    "phase": (DYNAMICS, "phase"),
    "soc": (BATTERY, "soc"), "consumed": (BATTERY, "consumed"), "voltage": (BATTERY, "voltage"),
    "current": (BATTERY, "current"), "energy": (BATTERY, "energy_used"),
    "state": (STRATEGY, "mission_state"), "target": (STRATEGY, "current_target"),
    "photos": (STRATEGY, "photo_count"), "photo_target": (STRATEGY, "last_photo_target"),
}


@dataclass
class Vehicle:
    index: int                     # in the monitor's list of UAVs
    name: str
    sysid: int
    command_input: str | None      # "uavK_strat.command", None when its strategy has no such input
    home: tuple[float, float]
    home_geo: tuple[float, float, float]
    mission: list[dict]            # MISSION_ITEM_INT fields (seq order)
    assigned: list[int]            # global target indices, in the order of the mission's waypoints


def _param(plan, qualified: str, default: float) -> float:
    """The value a run gives a parameter (the last entry of ``plan.params`` wins), else ``default``."""
    value = default
    for var, v, _origin in getattr(plan, "params", ()):
        if var.qualified == qualified:
            value = float(v)
    return value


def _geo(origin, east, north, up):
    lat, lon, alt = to_geodetic(origin, np.asarray(east, float), np.asarray(north, float), np.asarray(up, float))
    return np.atleast_1d(lat), np.atleast_1d(lon), np.atleast_1d(alt)


def _e7(deg) -> int:
    return int(round(float(deg) * 1e7))


class Fleet:
    """The vehicles of a UAV monitor's configuration and the buffer positions of their values."""

    def __init__(self, monitor, plan, forwarded=()):
        cfg = monitor.cfg
        self.monitor, self.origin = monitor, cfg.origin
        self.forwarded = list(forwarded)
        own = {f.uav for f in self.forwarded}
        taken = {f.sysid for f in self.forwarded}
        uavs = [u for u in cfg.uavs if u.name not in own]
        sysids = [s for s in range(1, MAX_VEHICLES + 1) if s not in taken][:len(uavs)]
        if len(uavs) > len(sysids):
            raise CosimError(f"{len(cfg.uavs)} UAVs: one MAVLink network addresses at most {MAX_VEHICLES} vehicles "
                             "(system ids 1-254; 255 is the ground station's)", element="--mavlink")
        self.frame = frame(cfg.origin) if len(cfg.uavs) <= SMALL_FLEET else None
        variables = getattr(plan, "variables", {})
        self.vehicles: list[Vehicle] = []
        self.qualified: dict[str, list[str | None]] = {c: [] for c in COLUMNS}
        targets = np.asarray(cfg.targets, float).reshape(-1, 2)
        tlat, tlon, _ = _geo(self.origin, targets[:, 0], targets[:, 1], np.zeros(len(targets)))
        for k, (u, sysid) in enumerate(zip(uavs, sysids)):
            for col, (part, var) in COLUMNS.items():
                comp = component(u.name, part)
                self.qualified[col].append(f"{comp}.{var}" if var in variables.get(comp, {}) else None)
            strat = component(u.name, STRATEGY)
            has_input = COMMAND_INPUT in variables.get(strat, {})
            cruise = _param(plan, f"{strat}.cruise_altitude", P.CRUISE_ALTITUDE)
            assigned = list(u.assigned or [])
            hlat, hlon, halt = _geo(self.origin, u.home[0], u.home[1], 0.0)
            self.vehicles.append(Vehicle(
                k, u.name, sysid, f"{strat}.{COMMAND_INPUT}" if has_input else None, u.home,
                (float(hlat[0]), float(hlon[0]), float(halt[0])),
                self._mission(u.home, (hlat[0], hlon[0]), cruise, assigned, tlat, tlon), assigned))
        self.fence = self._fence(cfg.zones)
        self.capacity_ah = [_param(plan, f"{component(u.name, BATTERY)}.capacity_ah", P.CAPACITY_AH)
                            for u in uavs]

    @staticmethod
    def _mission(home, home_geo, cruise, assigned, tlat, tlon) -> list[dict]:
        """Take-off over the pad, the assigned targets (waypoints, map order), return to launch."""
        from pymavlink.dialects.v20 import common as m
        rel = m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        items = [dict(frame=rel, command=m.MAV_CMD_NAV_TAKEOFF, x=_e7(home_geo[0]), y=_e7(home_geo[1]), z=cruise)]
        items += [dict(frame=rel, command=m.MAV_CMD_NAV_WAYPOINT, x=_e7(tlat[t]), y=_e7(tlon[t]), z=cruise)
                  for t in assigned]
        items.append(dict(frame=rel, command=m.MAV_CMD_NAV_RETURN_TO_LAUNCH, x=0, y=0, z=0.0))
        return items

    def _fence(self, zones) -> list[dict]:
        """Every restricted zone as a polygon of exclusion vertices (param1 = its vertex count)."""
        from pymavlink.dialects.v20 import common as m
        items = []
        for z in zones:
            poly = np.asarray(z["polygon"], float)
            lat, lon, _ = _geo(self.origin, poly[:, 0], poly[:, 1], np.zeros(len(poly)))
            items += [dict(frame=m.MAV_FRAME_GLOBAL_INT, command=m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
                           param1=float(len(poly)), x=_e7(a), y=_e7(b), z=0.0) for a, b in zip(lat, lon)]
        return items

    def required_variables(self) -> list[str]:
        own = [q for f in self.forwarded for q in f.variables]
        return [q for col in COLUMNS for q in self.qualified[col] if q is not None] + own

    def attach(self, ctx) -> None:
        """Index arrays per buffer type: one ``np.take`` per type reads every column of every vehicle into a
        (column, vehicle) table."""
        n = self.n = len(self.vehicles)
        cols = list(COLUMNS)
        self.table = np.full((len(cols), n), np.nan)
        by_type: dict[str, tuple[list, list]] = {}
        for c, col in enumerate(cols):
            for k, q in enumerate(self.qualified[col]):
                if q is not None:
                    typ, pos = ctx.position(q)
                    src, dst = by_type.setdefault(typ, ([], []))
                    src.append(pos)
                    dst.append(c * n + k)
        self._reads = [(ctx.buffer(typ), np.array(src, dtype=np.intp), np.array(dst, dtype=np.intp))
                       for typ, (src, dst) in by_type.items()]
        self.columns = {col: self.table[c] for c, col in enumerate(cols)}

    def read(self) -> dict[str, np.ndarray]:
        """Column -> values of every vehicle (float; NaN where the scenario lacks the variable)."""
        flat = self.table.reshape(-1)
        for buf, src, dst in self._reads:
            flat[dst] = buf[src]
        return self.columns

    def geodetic(self, x, y, z) -> list[tuple[float, float, float]]:
        """(lat, lon, alt) of each vehicle from ENU position arrays."""
        if self.frame is None:
            lat, lon, alt = _geo(self.origin, x, y, z)
            return list(zip(lat.tolist(), lon.tolist(), alt.tolist()))
        to = self.frame.to_geodetic
        return [to(a, b, c) for a, b, c in zip(x.tolist(), y.tolist(), z.tolist())]
