"""UAV-to-UAV broadcast radio: who hears whose message, when (the plain logic of the UavChannel FMU).

The paper's future work: "a communication channel between the UAVs, so that they can exchange messages between
them at certain distances, informing their future positions and points of visitation".  One channel serves the
whole fleet (as one network simulator would): every UAV broadcasts one message per ``period`` -- the message
number n is sent at n * period, its content sampled at the start of the step holding that instant -- and every
other UAV receives it

* if the two are within ``range`` m of each other (3-D distance at the sending instant),
* and, with ``line_of_sight``, if the straight line between them crosses no restricted zone (a zone is treated as
  a wall of unlimited height: a conservative choice for buildings or terrain),
* unless it is lost: an independent draw per (sender, receiver, message number) with probability ``loss``,
* ``latency`` s after it was sent, in the step whose interval [t, t + h) holds the arrival instant,
* among at most ``k`` messages arriving in that step, the nearest senders first (their distance when they sent;
  ties: the lower sender index);
  the others are dropped (counted as ``overflow``), so that a receiver's inputs stay k fixed-size slots whatever
  the fleet size.

Modes: ``radio`` (the above), ``perfect`` (unlimited range, no loss, no latency, no blocking; period and k as
given) and ``none`` (nothing is sent: the baseline of a silent channel).

A UAV transmits only while its strategy runs: its ``clock`` (the strategy's time) must have advanced since the
channel last looked, so a UAV removed from the simulation after a collision falls silent, as a destroyed radio.

The loss draws come from a counter-based generator: the uniform number of (seed, sender, receiver, message
number) is a pure function of those four integers (SplitMix64's finaliser applied to their combination), so a
run does not depend on the order in which pairs are evaluated, on how many pairs were in range, nor on the fleet
around a pair: the same seed gives the same losses, bit for bit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .zones_planning import ZoneMap, as_zones

#: the fields of one message, as the FMU's Real and Integer variables carry them (``wx``/``wy``: the waypoint the
#: sender flies to next; ``claims*``/``visited*``: bit masks of target indices, 32 per word; ``state``: its
#: mission state; ``target``: its current target, -1 none)
MESSAGE_REAL = ("x", "y", "z", "vx", "vy", "wx", "wy", "sent_time")
MESSAGE_INT = ("sender", "state", "target", "claims0", "claims1", "visited0", "visited1")
#: what a UAV hands to the channel each step (the broadcast's content, its own position included, and its clock)
BROADCAST_REAL = ("x", "y", "z", "vx", "vy", "wx", "wy", "clock")
BROADCAST_INT = ("state", "target", "claims0", "claims1", "visited0", "visited1")
MASK_WORDS = 2
#: the channel FMU's fixed capacity: fleet size and message slots per receiver (its ports are declared for these;
#: every port costs start-up time in every run, so the slots are as few as the strategy needs)
MAX_FLEET = 64
MAX_K = 4
MODES = ("none", "perfect", "radio")
#: the counters the FMU publishes for the fleet (totals) and per UAV (sent by it, received, lost on the way to it)
FLEET_COUNTERS = ("sent", "received", "lost", "out_of_range", "blocked", "overflow", "near_misses")
UAV_COUNTERS = ("sent", "received", "lost")
EMPTY = -1          # ``sender`` of an empty slot

_MASK64 = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15


_U64 = {c: np.uint64(c) for c in (11, 27, 30, 31, 0xBF58476D1CE4E5B9, 0x94D049BB133111EB, _GOLDEN,
                                   0xD1B54A32D192ED03)}


def _splitmix_finalize(z):
    """SplitMix64's output function (Steele, Lea, Flood 2014) on a Python int, or in place on a uint64 numpy array
    of one dimension or more (whose arithmetic wraps modulo 2**64 without a warning, unlike numpy's scalars)."""
    if isinstance(z, int):
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9 & _MASK64
        z = (z ^ (z >> 27)) * 0x94D049BB133111EB & _MASK64
        return z ^ (z >> 31)
    u = _U64
    z ^= z >> u[30]
    z *= u[0xBF58476D1CE4E5B9]
    z ^= z >> u[27]
    z *= u[0x94D049BB133111EB]
    z ^= z >> u[31]
    return z


def uniform(seed: int, sender, receiver, number: int):
    """The loss draw of message ``number`` from ``sender`` to ``receiver``: a uniform number in [0, 1), a pure
    function of the four integers (``sender``/``receiver`` may be integer arrays, broadcast together)."""
    key = _splitmix_finalize((int(seed) * _GOLDEN + 0x632BE59BD9B4E019) & _MASK64)
    key = _splitmix_finalize((key ^ (int(number) * _GOLDEN)) & _MASK64)
    s = np.asarray(sender, dtype=np.uint64)
    r = np.asarray(receiver, dtype=np.uint64)
    scalar = s.ndim == 0 and r.ndim == 0
    s, r = np.atleast_1d(s), np.atleast_1d(r)        # arrays: wrapping arithmetic, no overflow warning
    u = _U64
    z = _splitmix_finalize(s * u[_GOLDEN] ^ np.uint64(key))
    z = _splitmix_finalize(z ^ (r * u[0xD1B54A32D192ED03] + u[_GOLDEN]))
    out = (z >> u[11]).astype(np.float64) * (1.0 / 9007199254740992.0)
    return out[0] if scalar else out


def encode_mask(indices) -> tuple[int, ...]:
    """Target indices (0..63) as MASK_WORDS signed 32-bit words (FMI Integer), bit k % 32 of word k // 32."""
    words = [0] * MASK_WORDS
    for k in indices:
        k = int(k)
        if not 0 <= k < 32 * MASK_WORDS:
            raise ValueError(f"target index {k} outside 0..{32 * MASK_WORDS - 1}")
        words[k >> 5] |= 1 << (k & 31)
    return tuple(w - (1 << 32) if w >= 1 << 31 else w for w in words)


@lru_cache(maxsize=4096)
def decode_mask(*words) -> frozenset[int]:
    """The target indices of MASK_WORDS words (as encode_mask writes them); cached, a fleet repeats its masks."""
    out = set()
    for i, w in enumerate(words):
        w = int(w) & 0xFFFFFFFF
        while w:
            low = w & -w
            out.add(32 * i + low.bit_length() - 1)
            w ^= low
    return frozenset(out)


@dataclass
class ChannelParams:
    mode: str = "radio"
    range: float = 300.0            # m
    period: float = 1.0             # s between a UAV's broadcasts
    latency: float = 0.0            # s from sending to receiving
    loss: float = 0.0               # probability that a message in range is lost on the way to one receiver
    k: int = 4                      # messages a receiver takes per step, nearest senders first
    seed: int = 0
    line_of_sight: bool = False     # restricted zones block the line of sight
    zones: list = field(default_factory=list)   # polygons [(x, y), ...] (or the String form)
    n_uavs: int = 1
    near_miss: float = 10.0         # m, 3-D distance counted as a near miss (once per encounter of a pair)

    def check(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if int(self.n_uavs) < 1 or int(self.k) < 1:
            raise ValueError(f"n_uavs and k must be >= 1, got {self.n_uavs} and {self.k}")
        if not self.period > 0:
            raise ValueError(f"period must be > 0, got {self.period}")
        if not 0.0 <= self.loss <= 1.0:
            raise ValueError(f"loss must be in [0, 1], got {self.loss}")
        if not self.latency >= 0.0 or not self.range >= 0.0:
            raise ValueError("latency and range must be >= 0")


class Channel:
    """The fleet's radio.  :meth:`step` takes the UAVs' broadcasts at t and returns, per receiver, the messages
    arriving in [t, t + h) (at most k, nearest first); ``counters`` and ``uav_counters`` keep the totals.

    Its state is plain Python and public (``last_clock``, ``close_pairs``, ``in_flight``, the counters): the
    UavChannel FMU's compiled step (``_channel_ext.c``, the accelerator ``uavsim.channel-step`` of
    :meth:`advance`) reads and writes the same objects, so either step may follow the other."""

    #: time tolerance: instants within this of a step boundary belong to the step that starts there
    EPS = 1e-9

    def __init__(self, params: ChannelParams):
        params.check()
        self.p = params
        self.n = int(params.n_uavs)
        self.k = int(params.k)
        perfect = params.mode == "perfect"
        self.range = math.inf if perfect else float(params.range)
        self.latency = 0.0 if perfect else float(params.latency)
        self.loss = 0.0 if perfect else float(params.loss)
        self.zones = ZoneMap(as_zones(params.zones)) if params.line_of_sight and not perfect else None
        if self.zones is not None and not self.zones:
            self.zones = None
        #: the zones as records of their edges (zones_planning.zone_record), for the compiled step (_channel_ext.c)
        self.zone_records = self.zones.records() if self.zones is not None else []
        self.counters = dict.fromkeys(FLEET_COUNTERS, 0)
        self.uav_counters = {c: [0] * self.n for c in UAV_COUNTERS}
        self.last_clock = [None] * self.n
        # per sending instant: (arrival, [(distance, sender, receiver) of each pair it reaches], sender -> message)
        self.in_flight: list[tuple] = []
        self.close_pairs: set = set()                                       # pairs within the near-miss distance

    def _alive(self, clocks) -> list[bool]:
        last = self.last_clock
        alive = [c is None or clock != c for clock, c in zip(clocks, last)]
        self.last_clock = list(clocks)
        return alive

    def _count_near_misses(self, positions, alive) -> None:
        """Pairs (both alive) within ``near_miss`` now and not at the last step: one more encounter each.  A sweep
        along x: only UAVs within ``near_miss`` in x are compared."""
        lim = self.p.near_miss
        lim2 = lim * lim
        close = set()
        order = sorted((positions[i][0], i) for i in range(self.n) if alive[i])
        for a, (xa, i) in enumerate(order):
            _, yi, zi = positions[i]
            for xb, j in order[a + 1:]:
                if xb - xa > lim:
                    break
                _, yj, zj = positions[j]
                dx, dy, dz = xb - xa, yj - yi, zj - zi
                if dx * dx + dy * dy + dz * dz <= lim2:
                    close.add((i, j) if i < j else (j, i))
        if close:
            self.counters["near_misses"] += len(close - self.close_pairs)
        self.close_pairs = close

    def step(self, t: float, h: float, broadcasts: list[dict]) -> list[list[tuple]]:
        """``broadcasts[i]``: UAV i's BROADCAST_REAL and BROADCAST_INT values by name, sampled at t.  Returns per
        receiver the messages (MESSAGE_REAL + MESSAGE_INT values, a tuple) arriving in [t, t + h)."""
        out = self.advance(t, h, [(b["x"], b["y"], b["z"]) for b in broadcasts], [b["clock"] for b in broadcasts],
                           broadcasts.__getitem__)
        return out if out is not None else [[] for _ in range(self.n)]

    def sends_in(self, t: float, h: float) -> bool:
        """Does a broadcast instant fall in [t, t + h)?"""
        if self.p.mode == "none":
            return False
        period = float(self.p.period)
        return math.ceil((t - self.EPS) / period) * period < t + h - self.EPS

    def advance(self, t: float, h: float, positions, clocks, broadcast) -> list[list[tuple]] | None:
        """:meth:`step` on the UAVs' positions (x, y, z) and clocks at t, with ``broadcast(i)`` giving UAV i's
        whole broadcast (asked for only at a sending instant).  Returns None when nothing arrives."""
        alive = self._alive(clocks)
        self._count_near_misses(positions, alive)
        if self.sends_in(t, h):
            self._send(t, h, [broadcast(i) if alive[i] else None for i in range(self.n)], alive, positions)
        # messages fly in the order they arrive (one latency for all): the first is the next to arrive
        if not self.in_flight or self.in_flight[0][0] >= t + h - self.EPS:
            return None
        return self._deliver(t, h, alive)

    def _send(self, t, h, broadcasts, alive, positions) -> None:
        period = float(self.p.period)
        number = math.ceil((t - self.EPS) / period)
        while number * period < t + h - self.EPS:
            sent_at = number * period
            self._send_one(number, sent_at, broadcasts, alive, positions)
            number += 1

    def _send_one(self, number, sent_at, broadcasts, alive, positions) -> None:
        n = self.n
        senders = [i for i in range(n) if alive[i]]
        for i in senders:
            self.uav_counters["sent"][i] += 1
        self.counters["sent"] += len(senders)
        if not senders:
            return
        # the pairs in range, sender by sender, receivers in order: (distance when sent, sender, receiver); the
        # squares summed as (dx^2 + dy^2) + dz^2 (the accelerator and the results of earlier versions round so)
        pos = [(float(x), float(y), float(z)) for x, y, z in positions]
        pairs = []
        out_of_range = 0
        for i in senders:
            xi, yi, zi = pos[i]
            for j in range(n):
                if j == i or not alive[j]:
                    continue
                dx, dy, dz = xi - pos[j][0], yi - pos[j][1], zi - pos[j][2]
                d = math.sqrt((dx * dx + dy * dy) + dz * dz)
                if d <= self.range:
                    pairs.append((d, i, j))
                else:
                    out_of_range += 1
        self.counters["out_of_range"] += out_of_range
        if self.zones is not None:
            heard = [q for q in pairs if self.zones.blocked(pos[q[1]][:2], pos[q[2]][:2]) < 0]
            self.counters["blocked"] += len(pairs) - len(heard)
            pairs = heard
        if self.loss > 0.0 and pairs:
            draws = uniform(self.p.seed, np.array([q[1] for q in pairs]), np.array([q[2] for q in pairs]), number)
            kept = []
            lost = self.uav_counters["lost"]
            for q, u in zip(pairs, draws.tolist()):
                if u < self.loss:
                    lost[q[2]] += 1
                else:
                    kept.append(q)
            self.counters["lost"] += len(pairs) - len(kept)
            pairs = kept
        if not pairs:
            return
        # one entry per sending instant: its arrival, the pairs that reach, and the message of each sender among
        # them (made once per sender)
        messages = {}
        for _, i, _ in pairs:
            if i not in messages:
                b = broadcasts[i]
                messages[i] = (
                    float(b["x"]), float(b["y"]), float(b["z"]), float(b["vx"]), float(b["vy"]), float(b["wx"]),
                    float(b["wy"]), float(sent_at), i, int(b["state"]), int(b["target"]), int(b["claims0"]),
                    int(b["claims1"]), int(b["visited0"]), int(b["visited1"]))
        self.in_flight.append((sent_at + self.latency, pairs, messages))

    def _deliver(self, t, h, alive) -> list[list[tuple]]:
        end = t + h - self.EPS
        flying = self.in_flight
        cut = 0
        while cut < len(flying) and flying[cut][0] < end:      # in order of arrival (one latency for all)
            cut += 1
        arriving = flying[:cut]
        del flying[:cut]
        # per receiver, what reaches it from the instants arriving in this step, nearest first (the distance when
        # sent), ties by sender, then by arrival
        reaching: list[list] = [[] for _ in range(self.n)]
        for b, (_, pairs, messages) in enumerate(arriving):
            for d, i, j in pairs:
                reaching[j].append((d, i, b, messages[i]))
        out: list[list[tuple]] = [[] for _ in range(self.n)]
        k = self.k
        received = self.uav_counters["received"]
        for j, heard in enumerate(reaching):
            if not heard or not alive[j]:
                continue
            heard.sort(key=_nearest_first)
            taken = min(len(heard), k)
            self.counters["overflow"] += len(heard) - taken
            self.counters["received"] += taken
            received[j] += taken
            out[j] = [q[3] for q in heard[:taken]]
        return out


def _nearest_first(q):
    return q[0], q[1], q[2]
