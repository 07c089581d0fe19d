"""Strategy C: Strategy B plus what a UAV hears from the others over the channel (uavsim/channel.py).

Everything B does stays as it is (uavsim/strategy.py: the nearest remaining target first, the battery rules, the
paths around the zones); C adds two things, each driven only by received messages, so that a UAV that hears
nothing flies exactly as B (a silent channel degrades C to B, bit for bit):

**Target allocation: a consensus auction on claims with implicit distance bids** (after CBBA, Choi, Brunet and How
2009, reduced to what fits a bounded message).  The initial split is B's partition.  Every message carries the
sender's claims (its remaining targets, a bit mask), the targets it knows visited (its own and what it heard:
gossip that relays the news beyond one hop), its mission state, position and velocity.  A bid for target k is the
horizontal distance from a UAV's position to k (ties: the lower UAV index): every receiver can compute every
neighbour's bid from its broadcast position, so the message need not carry one number per target.  On hearing:

1. a target known visited leaves the remaining list;
2. a target claimed by an active neighbour with a better bid leaves it (the CBBA "outbid" rule);
3. targets become orphans when their claimant went home or landed early (its state is no longer PREFLIGHT,
   TAKEOFF, TRANSIT or RETURN_DONE, e.g. RETURN_LOW) or was lost: not heard for ``lost_timeout`` while active
   although it should be audible (judged once per silence: its last position carried on along its velocity for
   ``lost_timeout`` lies within 0.8 ``comm_range``, and in sight with ``comm_los``); a UAV silent because it
   flew out of range or behind a zone keeps its targets until it is heard again.
   Each orphan not claimed by an active neighbour nor known visited is auctioned locally: the UAV takes it when
   its own bid is the best among itself and the active neighbours that can fly it (TRANSIT, RETURN_DONE).  A UAV
   that had finished (RETURN_DONE) turns back to TRANSIT for it.

With a perfect channel every UAV computes the same winner; with loss or latency two may take the same orphan, and
rule 2 resolves it when they hear each other (or rule 1 when one has photographed it).  Why not the full CBBA
bundle with a bid per target: it needs the winning-bid list of every target in every message (64 Reals per
message here), and the paper's mission is a partition with few reassignments (after a loss), where the distance
bids everybody can compute give the same outcome.

**Collision mitigation: a right-of-way rule with altitude layers.**  On every message a UAV predicts, from the
sender's broadcast position (extrapolated over the message's age) and velocity, the horizontal closest point of
approach within ``horizon`` s; both velocities are the intent (towards the broadcast waypoint at cruise speed)
while a UAV is slower than half its cruise speed, so that UAVs just leaving the take-off ring, still at rest,
see where the others are going.  A predicted miss distance below ``separation`` is a conflict.  Of the pair, the
UAV with the higher index gives way: it climbs to the layer above the highest layer of those it gives way to
(``layer_step`` m per layer above the cruise altitude) and holds its horizontal position while it is less than
``vertical_clearance`` above such a UAV, if stopping keeps it out of the other's way (the other's path then
passes the point it brakes to 0.5 m farther than if both flew on, or, on a collision course, no closer: head-on,
where it halves the closing speed; in a crossing it flies on and climbs); the other keeps flying unless the closest approach is ``imminent`` s away or less and the give-way
UAV is not yet clear above it: then it waits too, under the same condition (at the ring of pads both are at
rest, 8 m apart, when their first legs start).  With no conflict left a UAV descends back to the cruise altitude.
Before its first leg a UAV broadcasts as its waypoint the target it will start with (B's choice from where it
stands), so the paths out are known before anyone moves; conflicts are assessed on every message and when the
first leg starts.  Why this and not ORCA (van den Berg et al. 2011): ORCA's reciprocity assumes both UAVs see each
other at the same time with the same data, which a lossy, late channel does not give (one UAV acting on the half
of the avoidance it assumes the other takes is worse than nothing); a right-of-way rule needs only the give-way
UAV to hear the other, which also holds when the channel is one-sided.  The altitude change suits the UAVs' ring
of pads at the base, where the paths out cross within seconds of take-off and no horizontal manoeuvre has room.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import channel as CH
from .assignment import next_target
from .strategy import (LAND_BASE, LAND_CMD, LAND_NOW, PREFLIGHT, RETURN_CMD, RETURN_DONE, RETURN_LOW, TAKEOFF,
                       TRANSIT, Strategy, StrategyParams)

#: states in which a UAV still owns its claims
ACTIVE = (PREFLIGHT, TAKEOFF, TRANSIT, RETURN_DONE)
#: states in which a UAV may take over targets
BIDDERS = (TRANSIT, RETURN_DONE)
#: states of a UAV in the air (a collision partner)
AIRBORNE = (TAKEOFF, TRANSIT, RETURN_DONE, RETURN_LOW, LAND_BASE, LAND_NOW, RETURN_CMD, LAND_CMD)
MAX_LAYERS = 4
_FIELDS = CH.MESSAGE_REAL + CH.MESSAGE_INT


@dataclass
class CoopParams:
    separation: float = 6.0           # m, predicted horizontal miss distance below which two UAVs conflict
    horizon: float = 10.0             # s, how far ahead conflicts are predicted
    layer_step: float = 5.0           # m between altitude layers
    vertical_clearance: float = 4.0   # m a give-way UAV must be above the other before it moves on
    lost_timeout: float = 5.0         # s without a message after which an active UAV counts as lost
    imminent: float = 3.0             # s: a right-of-way UAV waits for a give-way UAV this close to clear
    cruise_speed: float = 10.0        # m/s, the intent speed towards a broadcast waypoint
    comm_range: float = 1e9           # m, the radio's range: silence from farther away is no sign of a loss
    comm_los: bool = False            # the zones block the radio: silence from behind a zone is no sign either


class Neighbour:
    """What a UAV knows of another: its last message and when it arrived."""
    __slots__ = ("index", "x", "y", "z", "vx", "vy", "wx", "wy", "sent_time", "heard", "state", "target",
                 "claims", "visited", "lost")

    def __init__(self, message: tuple, heard: float):
        self.update(message, heard)

    def update(self, message: tuple, heard: float) -> None:
        (self.x, self.y, self.z, self.vx, self.vy, self.wx, self.wy, self.sent_time, self.index, self.state,
         self.target, c0, c1, v0, v1) = message
        self.claims = CH.decode_mask(c0, c1)
        self.visited = CH.decode_mask(v0, v1)
        self.heard = heard
        self.lost = None            # undecided; True / False once its silence was judged


class CoopState:
    """What C keeps beside B's MissionState: the neighbour table, the news, the avoidance and its counts."""
    __slots__ = ("neighbours", "known_visited", "layer", "holding", "conflicts", "imminent", "takeovers", "drops",
                 "give_ways", "next_expiry", "last_taken", "last_dropped")

    def __init__(self):
        self.neighbours: dict[int, Neighbour] = {}
        self.known_visited: set[int] = set()
        self.layer = 0                       # altitude layer flown (0: cruise)
        self.holding = False
        # (neighbour, its layer, its altitude, whether stopping helps) given way to
        self.conflicts: list[tuple[int, int, float, bool]] = []
        self.imminent: list[tuple[int, int, float, bool]] = []    # higher indices about to pass: wait for them
        self.takeovers = 0
        self.drops = 0
        self.give_ways = 0
        self.next_expiry = math.inf          # when the next active neighbour counts as lost
        # what the last allocation that took over / dropped anything did, (target, the other UAV's index) in
        # target order, for the events (the counts say when it changed): the UAV whose claim it was / the best
        # bidder that outbid this one
        self.last_taken: list[tuple[int, int]] = []
        self.last_dropped: list[tuple[int, int]] = []


def _bid(x, y, target) -> float:
    return math.hypot(target[0] - x, target[1] - y)


class CooperativeStrategy(Strategy):
    """Strategy B (its parent's step, unchanged) plus :meth:`hear`, the allocation and the avoidance."""

    def __init__(self, params: StrategyParams | None = None, coop: CoopParams | None = None):
        super().__init__(params)
        self.c = coop or CoopParams()
        self.coop = CoopState()

    # ------------------------------------------------------------------ what the UAV broadcasts
    def broadcast(self) -> tuple:
        """The message content of this UAV besides position and velocity: state, current target, claims (two
        words) and visited (two words, its own and those it heard of)."""
        m = self.mission
        return (int(m.state), int(m.current_target), *CH.encode_mask(m.remaining),
                *CH.encode_mask(self.coop.known_visited.union(m.visited)))

    def quiet(self, t: float) -> bool:
        """Nothing of C's can act in a step at t without a message: no avoidance under way (nor a conflict or an
        imminent pass watched, which :meth:`step` re-assesses every step), no neighbour due to be declared lost
        (then B's step, or its compiled twin, is C's whole step).  The one other thing :meth:`step` does without
        a message, assessing when the first leg starts, comes with B's state change, which the compiled twin
        leaves to this step."""
        return not self._avoiding() and t < self.coop.next_expiry

    def _avoiding(self) -> bool:
        c = self.coop
        return bool(c.layer or c.holding or c.conflicts or c.imminent)

    # ------------------------------------------------------------------ the step
    def step(self, t, x, y, z, vx, vy, phase, consumed, command=None, messages=()):
        c, m = self.coop, self.mission
        heard = bool(messages)
        for message in messages:
            self.hear(t, message)
        if heard or t >= c.next_expiry:
            self._allocate(t, x, y)
        was_flying = m.cmd == 2
        super().step(t, x, y, z, vx, vy, phase, consumed, command)
        avoiding = self._avoiding()
        # on news, when the first leg starts, and every step while avoiding: a conflict whose partner falls silent
        # ends when its extrapolated path clears or after lost_timeout, not with the next message
        if c.neighbours and (heard or avoiding or (m.cmd == 2 and not was_flying)):
            self._assess(t, x, y, z, vx, vy)
        if self._avoiding():
            self._avoid(x, y, z)

    def hear(self, t: float, message: tuple) -> None:
        c = self.coop
        j = int(message[_FIELDS.index("sender")])
        nb = c.neighbours.get(j)
        if nb is None:
            c.neighbours[j] = Neighbour(message, t)
        elif message[_FIELDS.index("sent_time")] >= nb.sent_time:
            nb.update(message, t)
        nb = c.neighbours[j]
        c.known_visited |= nb.visited

    # ------------------------------------------------------------------ allocation
    def _lost(self, nb: Neighbour, t: float, x: float, y: float) -> bool:
        """Silent for lost_timeout while active and where it should be heard (module docstring, rule 3)."""
        if nb.state not in ACTIVE or t - nb.heard < self.c.lost_timeout:
            return False
        if nb.lost is None:
            dt = self.c.lost_timeout
            px, py = nb.x + nb.vx * dt, nb.y + nb.vy * dt
            nb.lost = math.hypot(px - x, py - y) < 0.8 * self.c.comm_range and not (
                self.c.comm_los and self.zones and self.zones.blocked((x, y), (px, py)) >= 0)
        return nb.lost

    def _allocate(self, t, x, y) -> None:
        c, m = self.coop, self.mission
        timeout = self.c.lost_timeout
        expiries = [nb.heard + timeout for nb in c.neighbours.values()
                    if nb.state in ACTIVE and nb.heard + timeout > t]
        c.next_expiry = min(expiries) if expiries else math.inf
        if m.state not in BIDDERS:
            return
        me = int(self.p.uav_index)
        lost = {nb.index for nb in c.neighbours.values() if self._lost(nb, t, x, y)}
        active = [nb for nb in c.neighbours.values() if nb.state in ACTIVE and nb.index not in lost]
        gone = [nb for nb in c.neighbours.values() if nb.state not in ACTIVE or nb.index in lost]
        targets = self.targets
        keep, dropped, taken_now = [], [], []
        for k in m.remaining:
            if k in c.known_visited:
                continue                                    # rule 1: photographed by another
            mine = (_bid(x, y, targets[k]), me)
            better = [(_bid(nb.x, nb.y, targets[k]), nb.index) for nb in active if k in nb.claims]
            best = min(better) if better else None
            if best is not None and best < mine:
                c.drops += 1                                # rule 2: outbid
                dropped.append((k, best[1]))
                continue
            keep.append(k)
        taken = set(keep)
        if gone:
            claimed = set().union(*(nb.claims for nb in active)) if active else set()
            orphans = set().union(*(nb.claims for nb in gone)) - c.known_visited - claimed - taken - set(m.visited)
            bidders = [nb for nb in active if nb.state in BIDDERS]
            for k in sorted(k for k in orphans if 0 <= k < len(targets)):
                mine = (_bid(x, y, targets[k]), me)
                if all(mine < (_bid(nb.x, nb.y, targets[k]), nb.index) for nb in bidders):
                    keep.append(k)                          # rule 3: the best bid for an orphan
                    c.takeovers += 1
                    taken_now.append((k, min(nb.index for nb in gone if k in nb.claims)))
        if dropped:
            c.last_dropped = sorted(dropped)
        if taken_now:
            c.last_taken = taken_now
        if keep == m.remaining:
            return
        m.remaining = keep
        if m.current_target >= 0 and m.current_target not in keep:
            m.current_target = -1                           # B's step starts the next leg
        if m.state == RETURN_DONE and keep:
            m.state, m.current_target = TRANSIT, -1

    # ------------------------------------------------------------------ collision mitigation
    def _intent(self, x, y, vx, vy, wx, wy):
        """The velocity a UAV is predicted to fly: its own when it moves at half its cruise speed or more, else
        towards its waypoint at cruise speed (still at rest after take-off, it is about to leave)."""
        speed = self.c.cruise_speed
        if math.hypot(vx, vy) >= 0.5 * speed:
            return vx, vy
        dx, dy = wx - x, wy - y
        d = math.hypot(dx, dy)
        if d <= self.p.arrival_radius:
            return vx, vy
        return speed * dx / d, speed * dy / d

    def _layer_of(self, z: float) -> int:
        return max(0, min(MAX_LAYERS, round((z - self.p.cruise_altitude) / self.c.layer_step)))

    def _assess(self, t, x, y, z, vx, vy) -> None:
        """The conflicts with the neighbours heard, from their last messages: those with a lower index this UAV
        gives way to (``conflicts``), and those with a higher index that are imminent (``imminent``: closest
        approach within ``imminent`` s), for which it waits until the other has climbed clear."""
        c, m = self.coop, self.mission
        me = int(self.p.uav_index)
        conflicts, imminent = [], []
        if m.cmd == 2:
            sx, sy = m.sp[0], m.sp[1]
            ux, uy = self._intent(x, y, vx, vy, sx, sy)
            # where it would come to rest if it stopped now (braking at brake_accel)
            brake = math.hypot(vx, vy) / (2.0 * max(self.p.brake_accel, 1e-6))
            qx, qy = x + vx * brake, y + vy * brake
            for nb in c.neighbours.values():
                if nb.state not in AIRBORNE or t - nb.heard > self.c.lost_timeout:
                    continue
                age = t - nb.sent_time
                px, py = nb.x + nb.vx * age, nb.y + nb.vy * age
                nvx, nvy = self._intent(px, py, nb.vx, nb.vy, nb.wx, nb.wy)
                tc, miss = self._closest(px - x, py - y, nvx - ux, nvy - uy)
                if miss >= self.c.separation:
                    continue
                # stopping helps when the other's path then passes the point this UAV brakes to clearly farther than
                # if both flew on, or, on a collision course (miss < 1 m), no closer (head-on: it halves the closing
                # speed); when it would stop in the other's way (a crossing), it flies on and climbs
                stopped = self._closest(px - qx, py - qy, nvx, nvy)[1]
                stop = stopped >= miss + 0.5 or (miss < 1.0 and stopped >= miss - 0.5)
                if nb.index < me:                       # the lower index has the right of way
                    conflicts.append((nb.index, self._layer_of(nb.z), nb.z, stop))
                elif tc <= self.c.imminent:
                    imminent.append((nb.index, self._layer_of(nb.z), nb.z, stop))
        if conflicts and not c.conflicts:
            c.give_ways += 1
        c.conflicts, c.imminent = conflicts, imminent

    def giving_way_to(self) -> int:
        """The index of the UAV this one gives way to now (the lowest of its conflicts), -1 when none."""
        return min(j for j, *_ in self.coop.conflicts) if self.coop.conflicts else -1

    def _closest(self, rx, ry, wx, wy) -> tuple[float, float]:
        """Time (clamped to [0, horizon]) and distance of the closest approach of a relative position (rx, ry)
        moving at the relative velocity (wx, wy)."""
        w2 = wx * wx + wy * wy
        tc = 0.0 if w2 < 1e-12 else min(max(-(rx * wx + ry * wy) / w2, 0.0), self.c.horizon)
        return tc, math.hypot(rx + wx * tc, ry + wy * tc)

    def _avoid(self, x, y, z) -> None:
        c, m = self.coop, self.mission
        if m.cmd != 2:                                  # taking off or landing: the vehicle's own vertical leg
            c.layer, c.holding, c.conflicts, c.imminent = 0, False, [], []
            return
        clear = self.c.vertical_clearance
        if c.conflicts:
            c.layer = min(MAX_LAYERS, 1 + max(layer for _, layer, _, _ in c.conflicts))
        else:
            c.layer = 0
        c.holding = any(stop and z - nz < clear for _, _, nz, stop in c.conflicts) or \
            any(stop and abs(nz - z) < clear for _, _, nz, stop in c.imminent)
        sx, sy = (float(x), float(y)) if c.holding else (m.sp[0], m.sp[1])
        m.sp = (sx, sy, float(self.p.cruise_altitude) + c.layer * self.c.layer_step)

    def intent(self, x: float, y: float) -> tuple[float, float]:
        """Where this UAV is about to fly, for its broadcast: its setpoint once flying a leg, before that (on the
        ground, taking off) the target it will start with, so that the ring of pads knows the paths out before
        they cross."""
        m = self.mission
        if m.state in (PREFLIGHT, TAKEOFF):
            k = next_target(self.kind, m.remaining, self.targets, x, y)
            return self.targets[k] if k >= 0 else self.home
        return m.sp[0], m.sp[1]
