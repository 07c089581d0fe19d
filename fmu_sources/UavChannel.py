"""UavChannel FMU shell (pythonfmu): the fleet's UAV-to-UAV radio, uavsim.channel.Channel (docs/cooperative.md).

One instance serves the fleet.  Inputs per UAV ``uav{i}_<field>`` (i = 1..MAX_FLEET; the broadcast's content:
BROADCAST_REAL / BROADCAST_INT of uavsim/channel.py); outputs per receiving UAV ``uav{i}_m{s}_<field>`` for its
message slots s = 1..MAX_K (MESSAGE_REAL / MESSAGE_INT; ``sender`` -1: empty), holding the messages that arrived
during the last step, plus message counters for the fleet and per UAV.  On do_step(t, h) the inputs are those
sampled at t; the outputs are the deliveries in [t, t + h), so no output depends on an input of the same instant
(``output_dependencies`` declares none).  UAVs above ``n_uavs`` are not connected and not read.
"""
import os
import sys
from itertools import chain

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from uavsim import channel as C  # noqa: E402
from uavsim import native  # noqa: E402
from uavsim.fmi import StateMixin, UnitsMixin  # noqa: E402

# the compiled step (uavsim/_channel_ext.c, the library built with this FMU), None: the Python step alone
_EXT = native.load_extension("_channel_ext", os.path.join(_HERE, "uavsim"))
_ADVANCE = _EXT.advance if _EXT is not None else None

_UNITS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "wx": "m", "wy": "m", "sent_time": "s",
          "clock": "s"}
_PARAMS = [  # name, unit, default, description
    ("range", "m", 300.0, "radio range (3-D distance at the sending instant)"),
    ("period", "s", 1.0, "time between a UAV's broadcasts"),
    ("latency", "s", 0.0, "time from sending to receiving"),
    ("loss", "1", 0.0, "probability that a message in range is lost on the way to one receiver"),
    ("near_miss", "m", 10.0, "3-D distance counted as a near miss (once per encounter of a pair)"),
]


_FIELDS = C.MESSAGE_REAL + C.MESSAGE_INT


def _slot(i: int, s: int, name: str) -> str:
    return f"uav{i}_m{s}_{name}"


#: receiver j (0-based) -> slot s (0-based) -> its variable names in _FIELDS order
_SLOT_NAMES = [[tuple(_slot(j + 1, s + 1, name) for name in _FIELDS) for s in range(C.MAX_K)]
               for j in range(C.MAX_FLEET)]
_SENDER = _FIELDS.index("sender")
#: receiver j -> the names of all its slots in a row (slot 1's fields, slot 2's, ...)
_FLAT_NAMES = [tuple(name for slot in slots for name in slot) for slots in _SLOT_NAMES]
_BROADCAST = C.BROADCAST_REAL + C.BROADCAST_INT
#: UAV j (0-based) -> its broadcast inputs, in _BROADCAST order
_BROADCAST_NAMES = [tuple(f"uav{j + 1}_{name}" for name in _BROADCAST) for j in range(C.MAX_FLEET)]
#: the fleet's counters' outputs (C.FLEET_COUNTERS order)
_FLEET_COUNTER_NAMES = tuple(f"messages_{name}" if name != "near_misses" else name for name in C.FLEET_COUNTERS)
#: per UAV counter (C.UAV_COUNTERS order) -> its output of every UAV
_COUNTER_NAMES = [tuple(f"uav{j + 1}_{name}" for j in range(C.MAX_FLEET)) for name in C.UAV_COUNTERS]


class UavChannel(StateMixin, UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Broadcast radio between the UAVs: range, period, latency, seeded loss, k nearest, line of sight"
    # the outputs are the deliveries of the step just done: none depends on an input of the same instant
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _PARAMS:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        self.mode = "radio"
        self.par_str("mode", "radio, perfect (unlimited range, no loss, no latency) or none (nothing is sent)")
        self.zones = ""
        self.par_str("zones", "restricted zones blocking the line of sight: polygons 'x,y;...' separated by '|'")
        self.line_of_sight = False
        self.par_bool("line_of_sight", "restricted zones block the line of sight")
        for name, default, desc in [("k", 4, f"messages a UAV takes per step, nearest senders first (1..{C.MAX_K})"),
                                    ("seed", 0, "seed of the loss draws"),
                                    ("n_uavs", 1, f"UAVs in the fleet (1..{C.MAX_FLEET})")]:
            setattr(self, name, default)
            self.par_int(name, desc)
        for i in range(1, C.MAX_FLEET + 1):
            for name in C.BROADCAST_REAL:
                setattr(self, f"uav{i}_{name}", 0.0)
                self.in_real(f"uav{i}_{name}", _UNITS[name], f"UAV {i}'s broadcast: {name}")
            for name in C.BROADCAST_INT:
                setattr(self, f"uav{i}_{name}", 0 if name != "target" else -1)
                self.in_int(f"uav{i}_{name}", f"UAV {i}'s broadcast: {name}")
        for i in range(1, C.MAX_FLEET + 1):
            for s in range(1, C.MAX_K + 1):
                for name in C.MESSAGE_REAL:
                    setattr(self, _slot(i, s, name), 0.0)
                    self.out_real(_slot(i, s, name), _UNITS[name], f"UAV {i}'s message slot {s}: {name}")
                for name in C.MESSAGE_INT:
                    setattr(self, _slot(i, s, name), C.EMPTY if name == "sender" else 0)
                    self.out_int(_slot(i, s, name), f"UAV {i}'s message slot {s}: {name}")
        for name in C.FLEET_COUNTERS:
            setattr(self, f"messages_{name}" if name != "near_misses" else name, 0)
            self.out_int(f"messages_{name}" if name != "near_misses" else name, f"fleet total: {name}")
        for i in range(1, C.MAX_FLEET + 1):
            for name in C.UAV_COUNTERS:
                setattr(self, f"uav{i}_{name}", 0)
                self.out_int(f"uav{i}_{name}", f"messages {name} {'by' if name == 'sent' else 'for'} UAV {i}")
        self._model = None
        self._filled = [0] * C.MAX_FLEET      # slots holding a message since the last step, per receiver
        self._ports = None

    def _build(self):
        if not 1 <= int(self.n_uavs) <= C.MAX_FLEET or not 1 <= int(self.k) <= C.MAX_K:
            raise ValueError(f"n_uavs {self.n_uavs} and k {self.k}: this channel FMU has ports for 1..{C.MAX_FLEET} "
                             f"UAVs and 1..{C.MAX_K} message slots")
        self._model = C.Channel(C.ChannelParams(
            mode=str(self.mode), range=float(self.range), period=float(self.period), latency=float(self.latency),
            loss=float(self.loss), k=int(self.k), seed=int(self.seed), line_of_sight=bool(self.line_of_sight),
            zones=str(self.zones), n_uavs=int(self.n_uavs), near_miss=float(self.near_miss)))

    def exit_initialization_mode(self):
        self._build()

    def do_step(self, current_time, step_size):
        if self._model is None:
            self._build()
        model = self._model
        d = self.__dict__
        n = model.n
        sent = model.counters["sent"]
        # the compiled step reads the broadcasts from this FMU's variables by their names; NotImplemented: it
        # declined (a value it does not take), nothing done
        delivered = NotImplemented if _ADVANCE is None else \
            _ADVANCE(model, current_time, step_size, d, _BROADCAST_NAMES)
        if delivered is NotImplemented:
            ports = self._ports
            if ports is None or len(ports) != n:
                ports = self._ports = [(f"uav{i}_x", f"uav{i}_y", f"uav{i}_z", f"uav{i}_clock")
                                       for i in range(1, n + 1)]
            positions = [(d[x], d[y], d[z]) for x, y, z, _ in ports]
            clocks = [d[c] for *_, c in ports]

            def broadcast(j, _names=_BROADCAST_NAMES):
                return dict(zip(_BROADCAST, [d[name] for name in _names[j]]))
            delivered = model.advance(current_time, step_size, positions, clocks, broadcast)
        # each receiver's slots: the messages that arrived, the slots filled last step and not now emptied; the
        # messages of all receivers in one dict update (a fleet's deliveries are thousands of values)
        filled = self._filled
        arrived = delivered if delivered is not None else [()] * n
        names, values = [], []
        # nothing arrived and every slot empty already: no receiver to visit
        for j in range(n if delivered is not None or any(filled) else 0):
            messages = arrived[j]
            if messages:
                names += _FLAT_NAMES[j][:len(messages) * len(_FIELDS)]
                values += chain.from_iterable(messages)
            if len(messages) < filled[j]:
                for s in range(len(messages), filled[j]):
                    d[_SLOT_NAMES[j][s][_SENDER]] = C.EMPTY
            filled[j] = len(messages)
        if names:
            d.update(zip(names, values))
        if delivered is not None or model.counters["sent"] != sent or \
                model.counters["near_misses"] != d["near_misses"]:
            self._publish_counters()
        return True

    def _publish_counters(self) -> None:
        d, model = self.__dict__, self._model
        d.update(zip(_FLEET_COUNTER_NAMES, map(model.counters.__getitem__, C.FLEET_COUNTERS)))
        for name, names in zip(C.UAV_COUNTERS, _COUNTER_NAMES):
            d.update(zip(names, model.uav_counters[name]))
