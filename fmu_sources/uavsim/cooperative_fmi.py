"""Strategy C's variables on the UavStrategy FMU shell and its step there (the shell stays a thin dispatcher).

Every UavStrategy instance has them (one modelDescription for A, B and C; unconnected under A and B):

* parameters of the avoidance and the allocation (uavsim/cooperative.py, ``CoopParams``);
* inputs ``m{s}_<field>``, s = 1..MAX_K: the message slots the channel fills (uavsim/channel.py, ``MESSAGE_*``;
  ``m{s}_sender`` -1: empty), the messages that arrived in the channel's last step;
* outputs for the channel (``clock``, the time the strategy has reached: a UAV whose strategy stopped falls
  silent; ``intent_x/y``, where it is about to fly; ``claims*``/``visited*``, bit masks of target indices) and
  counts of what C did.
"""
from __future__ import annotations

from . import channel as CH
from .cooperative import CoopParams, CooperativeStrategy
from .strategy import PREFLIGHT, TAKEOFF

BEFORE_FIRST_LEG = (PREFLIGHT, TAKEOFF)

PARAMS = [  # name, unit, description (defaults: CoopParams)
    ("separation", "m", "strategy C: predicted horizontal miss distance below which two UAVs conflict"),
    ("horizon", "s", "strategy C: how far ahead conflicts are predicted"),
    ("layer_step", "m", "strategy C: height between altitude layers"),
    ("vertical_clearance", "m", "strategy C: height a give-way UAV gains over the other before it moves on"),
    ("lost_timeout", "s", "strategy C: silence after which an active UAV counts as lost"),
    ("cruise_speed", "m/s", "strategy C: speed assumed towards a broadcast waypoint"),
    ("comm_range", "m", "strategy C: the radio's range (silence from farther away is no sign of a loss)"),
]
_DEFAULTS = CoopParams()
SLOT_FIELDS = CH.MESSAGE_REAL + CH.MESSAGE_INT
_UNITS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "wx": "m", "wy": "m", "sent_time": "s"}
BROADCAST_OUTPUTS = ("claims0", "claims1", "visited0", "visited1")
COUNT_OUTPUTS = (("takeovers", "strategy C: orphaned targets taken over"),
                 ("drops", "strategy C: targets dropped to a better bid"),
                 ("give_ways", "strategy C: conflicts in which this UAV gave way"))
#: what C's last takeover / drop / give-way was, for the events (uavstudy/comm_monitor.py): the counts above say
#: when a takeover or drop happened, these which targets and with whom
EVENT_OUTPUTS = (("taken0", "strategy C: targets taken over in the last step that took any over, bit mask word 0"),
                 ("taken1", "strategy C: targets taken over in the last step that took any over, bit mask word 1"),
                 ("taken_from", "strategy C: index of the UAV whose claim the lowest of those targets was"),
                 ("dropped0", "strategy C: targets dropped in the last step that dropped any, bit mask word 0"),
                 ("dropped1", "strategy C: targets dropped in the last step that dropped any, bit mask word 1"),
                 ("dropped_to", "strategy C: index of the best bidder for the lowest of those targets"),
                 ("give_way_to", "strategy C: index of the UAV this one gives way to now (-1: none)"))
SLOTS = [[f"m{s}_{name}" for name in SLOT_FIELDS] for s in range(1, CH.MAX_K + 1)]
_SENDERS = [f"m{s}_sender" for s in range(1, CH.MAX_K + 1)]


def register(shell) -> None:
    """Register C's variables on a UavStrategy shell (after its own)."""
    for name, unit, desc in PARAMS:
        setattr(shell, name, float(getattr(_DEFAULTS, name)))
        shell.par_real(name, unit, desc)
    for slot in SLOTS:
        for name in slot:
            field = name.split("_", 1)[1]
            if field in CH.MESSAGE_REAL:
                setattr(shell, name, 0.0)
                shell.in_real(name, _UNITS[field], f"received message: {field}")
            else:
                setattr(shell, name, CH.EMPTY if field == "sender" else 0)
                shell.in_int(name, f"received message: {field}" + (" (-1: empty slot)" if field == "sender" else ""))
    shell.comm_los = False
    shell.par_bool("comm_los", "strategy C: the zones block the radio (silence from behind a zone is no sign of loss)")
    shell.clock = 0.0
    for name, desc in (("intent_x", "east"), ("intent_y", "north")):
        setattr(shell, name, 0.0)
        shell.out_real(name, "m", f"broadcast: {desc} of the waypoint flown to (before the first leg: its target)")
    shell.out_real("clock", "s", "time the strategy has reached (the channel hears a UAV while it advances)")
    for name in BROADCAST_OUTPUTS:
        setattr(shell, name, 0)
        shell.out_int(name, f"broadcast: {name[:-1]} targets, bit mask word {name[-1]}")
    for name, desc in COUNT_OUTPUTS:
        setattr(shell, name, 0)
        shell.out_int(name, desc)
    for name, desc in EVENT_OUTPUTS:
        setattr(shell, name, -1 if name in ("taken_from", "dropped_to", "give_way_to") else 0)
        shell.out_int(name, desc)


def make(shell, params):
    """The strategy a shell steps: Strategy C's (params.strategy 'C') with its parameters from the shell."""
    return CooperativeStrategy(params, CoopParams(**{n: float(getattr(shell, n)) for n, *_ in PARAMS},
                                                  comm_los=bool(shell.comm_los)))


def step(shell, model: CooperativeStrategy, t: float, h: float, fast_step) -> None:
    """One step of a C strategy on the shell's variables: the messages in, B's step (its compiled twin when C
    has nothing to do), the outputs and the broadcast out."""
    d = shell.__dict__
    # the channel fills the slots in order: an empty first slot means no message
    messages = [tuple(d[n] for n in slot) for slot, sender in zip(SLOTS, _SENDERS) if d[sender] >= 0] \
        if d["m1_sender"] >= 0 else ()
    d["clock"] = t + h
    # the compiled step publishes none of C's outputs: the first step (no broadcast key yet) is Python's, which
    # publishes the claims, visited and counts; later quiet steps change none of them
    if not messages and fast_step is not None and "_broadcast_key" in d and model.quiet(t) and \
            fast_step(model.step_constants, model.mission, d):
        # nothing happened (no arrival, no new leg): the claims and counts are as they were, the intent is the
        # setpoint once flying (before that the first target)
        if model.mission.state in BEFORE_FIRST_LEG:
            d["intent_x"], d["intent_y"] = model.intent(d["x"], d["y"])
        else:
            d["intent_x"], d["intent_y"] = d["sp_x"], d["sp_y"]
        return
    model.step(t, d["x"], d["y"], d["z"], d["vx"], d["vy"], int(d["phase"]), d["consumed"], d["command"],
               messages=messages)
    shell._publish()
    d["intent_x"], d["intent_y"] = model.intent(d["x"], d["y"])
    m, c = model.mission, model.coop
    # the bit masks change only with the lists they encode (visited and known_visited only grow)
    key = (tuple(m.remaining), len(m.visited), len(c.known_visited), c.takeovers, c.drops, c.give_ways)
    if key != d.get("_broadcast_key"):
        d["_broadcast_key"] = key
        d["claims0"], d["claims1"], d["visited0"], d["visited1"] = model.broadcast()[2:]
        d["takeovers"], d["drops"], d["give_ways"] = c.takeovers, c.drops, c.give_ways
        if c.last_taken:
            d["taken0"], d["taken1"] = CH.encode_mask([k for k, _ in c.last_taken])
            d["taken_from"] = c.last_taken[0][1]
        if c.last_dropped:
            d["dropped0"], d["dropped1"] = CH.encode_mask([k for k, _ in c.last_dropped])
            d["dropped_to"] = c.last_dropped[0][1]
    d["give_way_to"] = model.giving_way_to()
