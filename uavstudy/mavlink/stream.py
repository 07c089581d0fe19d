"""The UAV fleet as live MAVLink vehicles: an observer that streams, a manipulator that takes commands.

What each vehicle sends (encoded in the streaming process, :mod:`uavstudy.mavlink.server`):
GLOBAL_POSITION_INT and ATTITUDE at ``rate`` per simulated second; HEARTBEAT, VFR_HUD, SYS_STATUS,
BATTERY_STATUS, EXTENDED_SYS_STATE and MISSION_CURRENT once a simulated second; HOME_POSITION every 5 s; a
STATUSTEXT for every event the UAV monitor emitted (and every removal), for every decision of strategy C (a
takeover, a drop, a give-way and its end: the comm monitor's events), for every photo (with
MISSION_ITEM_REACHED) and for every command; COMMAND_ACK of the commands applied.

``VehicleStream`` (observer, after the UAV monitor): after a step that is a tick of the stream, or that has
new events or applied commands, it reads the fleet's values (one ``np.take`` per buffer type) and hands them
to the streaming process, which it starts when the run starts and stops when the run ends.

``CommandInput`` (manipulator): before every step it takes the commands the streaming process passed on
and writes a return or land command into the UAV strategy's ``command`` input, which the strategy takes in
this step; the input goes back to 0 before the next one, so that a repeated command is a change again.
After the step the observer tells from the strategy's mission state whether it was taken (COMMAND_ACK
accepted or denied) and records it as an event (type ``command``) in events.csv.
"""
from __future__ import annotations

import fcntl
import logging
import multiprocessing as mp
import os
import select
import time

from pymavlink.dialects.v20 import common as m

from master.manipulators import Manipulator
from master.observers import Observer
from uavsim.strategy import COMMAND_LAND, COMMAND_NONE, COMMAND_RETURN, LAND_CMD, RETURN_CMD, STATE_NAMES

from ..names import MISSION_DETAIL
from .links import open_link
from .server import SLOW_HZ, StreamServer, serve, ticks

log = logging.getLogger("cosim_master")
#: MAVLink command -> (value of the strategy's command input, mission state that shows it taken, event name)
COMMANDS = {m.MAV_CMD_NAV_RETURN_TO_LAUNCH: (COMMAND_RETURN, RETURN_CMD, "return_to_launch"),
            m.MAV_CMD_NAV_LAND: (COMMAND_LAND, LAND_CMD, "land")}
STREAMED_EVENTS = ("mission", "uav", "zone", "coop")
#: the pipe to the streaming process holds this many bytes (Linux F_SETPIPE_SZ; the default is 64 kB): ~1600
#: ticks of a 4-UAV fleet, ~25 of a 254-UAV one
PIPE_BYTES = 1 << 20
F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
#: ticks go to the streaming process in batches, at most this many and this old (wall clock): each hand-over
#: wakes that process, which costs the simulation more than the bytes
BATCH, BATCH_S = 64, 0.05


class Hub:
    """What the observer and the manipulator share: the fleet, the links, the streaming process."""

    def __init__(self, fleet, links, rate: float):
        self.fleet, self.links, self.rate = fleet, links, float(rate)
        self.relays: list = []                # the forwarded vehicles' own streams (forward.py)
        self.conn = None
        self.pid = None
        self.broken = False
        self.stats: dict = {}
        self.applied: list = []              # (vehicle, command, requester, link index, time) of this step

    def open_relays(self, read) -> None:
        """Connect to the forwarded vehicles' own streams: after initialisation, when their firmware runs."""
        try:
            for f in self.fleet.forwarded:
                self.relays.append(open_link(f.address(read)))
                self.relays[-1].quiet = True
        except BaseException:
            for link in self.links + self.relays:
                link.close()
            raise

    def start(self) -> None:
        """Fork the streaming process; from then on it alone holds the links."""
        ours, theirs = mp.Pipe(duplex=True)
        pid = os.fork()
        if pid == 0:                          # the streaming process
            status = 0
            try:
                ours.close()
                server = StreamServer(self.fleet, self.links, self.rate,
                                      lambda *c: theirs.send(("cmd", *c)), self.relays)
                serve(server, theirs)
            except BaseException:  # noqa: BLE001 - nothing of this process may run the simulation's exit code
                status = 1
            finally:
                os._exit(status)
        theirs.close()
        for link in self.links + self.relays:
            link.close()
        self.conn, self.pid = ours, pid
        self.dropped = 0
        self.batch, self.batch_at = [], time.monotonic()
        try:
            fcntl.fcntl(ours.fileno(), F_SETPIPE_SZ, PIPE_BYTES)
        except OSError:
            pass                              # a smaller pipe only drops more ticks when the process lags

    def offer(self, record, urgent: bool) -> None:
        """Queue a tick; hand the batch over when it is full, old, or holds events or command results (those
        at once).  When the streaming process lags (the pipe is full), the ticks that carry only telemetry are
        dropped: the simulation never waits for the stream."""
        self.batch.append((record, urgent))
        now = time.monotonic()
        if not (urgent or len(self.batch) >= BATCH or now - self.batch_at >= BATCH_S):
            return
        self.batch_at = now
        batch, self.batch = self.batch, []
        if self.conn is not None and not select.select([], [self.conn.fileno()], [], 0)[1]:
            self.dropped += sum(1 for _, u in batch if not u)
            batch = [(r, u) for r, u in batch if u]
            if not batch:
                return
        self.send(("ticks", [r for r, _ in batch]))

    def send(self, record) -> None:
        if self.broken or self.conn is None:
            return
        try:
            self.conn.send(record)
        except OSError as exc:
            self.broken = True
            log.warning("--mavlink: the streaming process is gone (%s); the run goes on without it", exc)

    def commands(self) -> list:
        out = []
        if self.conn is None or self.broken:
            return out
        fd = self.conn.fileno()
        try:
            # select, not Connection.poll: this runs before every step, and poll costs ~50 times more
            while select.select([fd], [], [], 0)[0]:
                msg = self.conn.recv()
                if msg[0] == "cmd":
                    out.append(msg[1:])
        except (EOFError, OSError):
            self.broken = True
        return out

    def stop(self) -> None:
        if self.conn is None:
            for link in self.links + self.relays:
                link.close()
            return
        if getattr(self, "batch", None):
            self.send(("ticks", [r for r, _ in self.batch]))
        self.send(("stop",))
        try:
            while not self.broken and self.conn.poll(5.0):
                msg = self.conn.recv()
                if msg[0] == "stats":
                    self.stats = msg[1]
                    break
        except (EOFError, OSError):
            pass
        self.conn.close()
        self.conn = None
        try:
            os.waitpid(self.pid, 0)
        except ChildProcessError:
            pass


class CommandInput(Manipulator):
    name = "mavlink-commands"

    def __init__(self, hub: Hub):
        self.hub = hub
        self.to_reset: list[str] = []

    def before_step(self, n: int, t: float) -> None:
        for q in self.to_reset:
            self.ctx.set_value(q, COMMAND_NONE)
        self.to_reset = []
        hub = self.hub
        for vehicle, command, requester, link in hub.commands():
            q = hub.fleet.vehicles[vehicle].command_input
            self.ctx.set_value(q, COMMANDS[command][0])
            if q not in self.to_reset:
                self.to_reset.append(q)
            hub.applied.append((vehicle, command, tuple(requester), link, t))


class VehicleStream(Observer):
    name = "mavlink"

    def __init__(self, hub: Hub, monitor):
        self.hub, self.monitor = hub, monitor
        self.commands: list[dict] = []

    def required_variables(self) -> list[str]:
        return self.hub.fleet.required_variables()

    def attach(self, ctx, start: float) -> None:
        super().attach(ctx, start)
        fleet = self.hub.fleet
        fleet.attach(ctx)
        self.events_seen = len(ctx.events)

        def read(qualified):
            typ, pos = ctx.position(qualified)
            return ctx.buffer(typ)[pos]
        self.hub.open_relays(read)
        self.hub.start()
        fleet.read()
        self.hub.send(("start", start, fleet.table.tobytes()))

    def after_step(self, n: int, t0: float, t1: float) -> None:
        hub = self.hub
        events = self.ctx.events
        new = len(events) > self.events_seen
        if not (new or hub.applied or ticks(t0, t1, hub.rate) or ticks(t0, t1, SLOW_HZ)):
            return
        fleet = hub.fleet
        fleet.read()
        streamed = []
        if new:
            streamed = [(e.get("type"), e.get("event"), e.get("uav"), e.get("other"), e.get("detail") or "")
                        for e in events[self.events_seen:] if e.get("type") in STREAMED_EVENTS]
        acks = self._taken(fleet.columns) if hub.applied else []
        self.events_seen = len(events)       # our own command events are not sent back as monitor events
        hub.offer((t0, t1, fleet.table.tobytes(), streamed, acks), bool(streamed or acks))

    def _taken(self, cols) -> list:
        """Did the strategy take the commands of this step?  Each becomes an event; the acks go out."""
        hub, acks = self.hub, []
        for k, command, requester, link, t in hub.applied:
            _code, state_taken, what = COMMANDS[command]
            v = hub.fleet.vehicles[k]
            state = cols["state"][k]
            taken = state == state and int(state) == state_taken
            now = STATE_NAMES[int(state)] if state == state else "unknown"
            x, y, z = (float(cols[a][k]) for a in ("x", "y", "z"))
            lat, lon, alt = hub.fleet.geodetic(*(cols[a][k:k + 1] for a in ("x", "y", "z")))[0]
            self.ctx.emit({"time": round(float(t), 9), "type": "command", "event": what, "uav": v.name,
                           "other": f"gcs {requester[0]}/{requester[1]} via {hub.links[link].url}",
                           "x": x, "y": y, "z": z, "lat": lat, "lon": lon, "alt": alt, "distance": None,
                           "consumed": float(cols["consumed"][k]),
                           "detail": ("accepted: " + MISSION_DETAIL.get(state_taken, "")) if taken
                           else f"denied: refused by the strategy in state {now}"})
            self.commands.append({"time": round(float(t), 9), "uav": v.name, "command": what,
                                  "result": "accepted" if taken else "denied"})
            acks.append((k, command, requester, what, taken))
        hub.applied = []
        return acks

    def finish(self, out_dir, outcome) -> dict:
        hub = self.hub
        hub.stop()
        forwarded = [{"uav": f.uav, "sysid": f.sysid, "from": ln.url} for f, ln in zip(hub.fleet.forwarded, hub.relays)]
        return {"vehicles": len(hub.fleet.vehicles), "links": [ln.url for ln in hub.links], **hub.stats,
                **({"forwarded": forwarded} if forwarded else {}),
                "ticks_dropped": getattr(hub, "dropped", 0), "commands": self.commands}
