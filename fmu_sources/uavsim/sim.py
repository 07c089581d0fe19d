"""Plain-Python closed loop of the four UAV models (one UAV), for tests and quick studies.

It wires the models exactly as the SSP scenario does (strategy -> dynamics -> battery, wind ->
dynamics) with a fixed communication step and Jacobi-style exchange: every model is stepped from
t to t+h with the outputs all models had at t.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .battery import Battery
from .dynamics import Dynamics, DynamicsParams
from .strategy import LANDED_AWAY, LANDED_BASE, Strategy, StrategyParams
from .wind import Wind, WindParams


@dataclass
class MissionResult:
    t: list = field(default_factory=list)
    x: list = field(default_factory=list)
    y: list = field(default_factory=list)
    z: list = field(default_factory=list)
    consumed: list = field(default_factory=list)
    state: list = field(default_factory=list)
    strategy: Strategy | None = None
    dynamics: Dynamics | None = None
    battery: Battery | None = None


def simulate_mission(strategy: StrategyParams, dynamics: DynamicsParams | None = None,
                     wind: WindParams | None = None, battery: Battery | None = None,
                     step: float = 0.1, t_end: float = 3600.0, record_every: int = 10) -> MissionResult:
    s = Strategy(strategy)
    dp = dynamics or DynamicsParams(home_x=strategy.home_x, home_y=strategy.home_y,
                                    takeoff_altitude=strategy.cruise_altitude)
    d = Dynamics(dp)
    b = battery or Battery()
    w = Wind(wind or WindParams())
    res = MissionResult(strategy=s, dynamics=d, battery=b)
    t = 0.0
    i = 0
    wx, wy, wz, _ = w.at(0.0)
    while t < t_end - 1e-9:
        # outputs at t
        x, y, z = d.pos
        vx, vy, vz = d.ground_velocity
        airspeed, phase, consumed = d.airspeed, d.phase, b.consumed
        cmd, sp = s.cmd, s.sp
        # step all models t -> t+h
        s.step(t, x, y, z, vx, vy, phase, consumed)
        d.step(step, cmd, sp, (wx, wy, wz))
        b.step(step, airspeed, vz, phase)
        t = round((i + 1) * step, 9)
        i += 1
        wx, wy, wz, _ = w.at(t)
        if i % record_every == 0:
            res.t.append(t)
            res.x.append(d.pos[0])
            res.y.append(d.pos[1])
            res.z.append(d.pos[2])
            res.consumed.append(b.consumed)
            res.state.append(s.state)
        if s.state in (LANDED_BASE, LANDED_AWAY) and d.phase == 4:
            break
    return res
