"""Plain-Python closed loop of a fleet with its channel (as uavstudy/build.py wires the SSP), for tests and quick
studies of strategy C.

Each UAV is a dynamics, a battery (no wind) and a strategy; the channel (uavsim/channel.py) hears every UAV's
broadcast and hands each its messages, all exchanged Jacobi-style (every model steps from t to t + h on the
outputs all had at t; the messages a strategy reads at t are those the channel delivered in the step before).
``remove`` takes UAVs out at given times, as the UAV monitor does after a collision: they no longer step, so they
fall silent.  The closest 3-D approach of every pair is measured over each step (positions linear in between).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import channel as CH
from .battery import Battery
from .cooperative import CooperativeStrategy
from .dynamics import Dynamics, DynamicsParams
from .strategy import LANDED_AWAY, LANDED_BASE, Strategy, StrategyParams


@dataclass
class FleetResult:
    strategies: list
    dynamics: list
    channel: CH.Channel | None
    t: float = 0.0
    closest: dict = field(default_factory=dict)     # (i, j) -> closest 3-D distance of the pair (m)
    first_contact: dict = field(default_factory=dict)   # (i, j) -> time the pair came within the contact distance


def _closest(p0, p1, q0, q1) -> float:
    """Closest distance of two points moving linearly from p0 to p1 and q0 to q1 over the same interval."""
    r = [b - a for a, b in zip(p0, q0)]
    u = [(b1 - b0) - (a1 - a0) for a0, a1, b0, b1 in zip(p0, p1, q0, q1)]
    uu = sum(c * c for c in u)
    s = 0.0 if uu < 1e-15 else min(max(-sum(a * b for a, b in zip(r, u)) / uu, 0.0), 1.0)
    return math.sqrt(sum((a + b * s) ** 2 for a, b in zip(r, u)))


def simulate_fleet(params: list[StrategyParams], channel: CH.ChannelParams | None = None, coop=None,
                   step: float = 0.1, t_end: float = 600.0, remove: dict | None = None,
                   contact: float = 2.6, dynamics: list | None = None) -> FleetResult:
    """Fly the fleet until every UAV has landed (or was removed) or ``t_end``."""
    strategies = [CooperativeStrategy(p, coop) if p.strategy.upper() == "C" else Strategy(p) for p in params]
    dyn = dynamics or [Dynamics(DynamicsParams(home_x=p.home_x, home_y=p.home_y, takeoff_altitude=p.cruise_altitude))
                       for p in params]
    bats = [Battery() for _ in params]
    ch = CH.Channel(channel) if channel is not None else None
    remove = remove or {}
    n = len(params)
    inbox = [[] for _ in range(n)]
    res = FleetResult(strategies, dyn, ch)
    clocks = [0.0] * n
    t, i = 0.0, 0
    while t < t_end - 1e-9:
        alive = [not (k in remove and t >= remove[k] - 1e-9) for k in range(n)]
        outs = [(d.pos, d.ground_velocity, d.airspeed, d.phase) for d in dyn]
        cmds = [(s.cmd, s.sp) for s in strategies]
        if ch is not None:
            broadcasts = []
            for k, s in enumerate(strategies):
                (x, y, z), (vx, vy, _), _, _ = outs[k]
                state, target, c0, c1, v0, v1 = s.broadcast() if isinstance(s, CooperativeStrategy) else \
                    (s.state, s.current_target, 0, 0, 0, 0)
                wx, wy = s.intent(x, y) if isinstance(s, CooperativeStrategy) else s.sp[:2]
                broadcasts.append({"x": x, "y": y, "z": z, "vx": vx, "vy": vy, "wx": wx, "wy": wy,
                                   "clock": clocks[k], "state": state, "target": target, "claims0": c0,
                                   "claims1": c1, "visited0": v0, "visited1": v1})
            delivered = ch.step(t, step, broadcasts)
        for k, s in enumerate(strategies):
            if not alive[k]:
                continue
            (x, y, z), (vx, vy, _), airspeed, phase = outs[k]
            if isinstance(s, CooperativeStrategy):
                s.step(t, x, y, z, vx, vy, phase, bats[k].consumed, messages=inbox[k])
            else:
                s.step(t, x, y, z, vx, vy, phase, bats[k].consumed)
            clocks[k] = t + step
        before = [tuple(d.pos) for d in dyn]
        for k in range(n):
            if alive[k]:
                dyn[k].step(step, cmds[k][0], cmds[k][1])
                bats[k].step(step, outs[k][2], outs[k][1][2], outs[k][3])
        if ch is not None:
            inbox = delivered
        i += 1
        t = round(i * step, 9)
        after = [tuple(d.pos) for d in dyn]
        for a in range(n):
            for b in range(a + 1, n):
                if alive[a] and alive[b] and min(dyn[a].pos[2], dyn[b].pos[2]) > 0.5:
                    d = _closest(before[a], after[a], before[b], after[b])
                    if d < res.closest.get((a, b), math.inf):
                        res.closest[(a, b)] = d
                    if d <= contact and (a, b) not in res.first_contact:
                        res.first_contact[(a, b)] = t
        if all(not alive[k] or (s.state in (LANDED_BASE, LANDED_AWAY) and dyn[k].phase == 4)
               for k, s in enumerate(strategies)):
            break
    res.t = t
    return res
