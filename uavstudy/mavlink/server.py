"""The streaming process: everything MAVLink, away from the simulation's process.

Encoding a fleet's telemetry costs far more than reading it (pure-Python packing, WGS84 conversion of every
position): done in the simulation's process it doubled the CPU time of the 4-UAV mission.  So the
simulation hands each tick's values (one table of floats, the new events, the results of commands) through a
pipe to this process, forked when the run starts, which encodes and sends them, answers the ground stations
(mission and fence downloads, requests) and passes their commands back.  On a machine with a free core the
stream then costs the run little more than the pipe.

``StreamServer.tick`` does per record what the module docstring of :mod:`uavstudy.mavlink.stream` lists;
``serve`` is the process's loop: records from the simulation, bytes from the links, until the simulation
says stop or its end of the pipe closes.
"""
from __future__ import annotations

import math
import signal
import time
from multiprocessing.connection import wait

import numpy as np
from pymavlink.dialects.v20 import common as m

from uavsim.strategy import STATE_NAMES

from .fleet import COLUMNS
from .frames import packed
from .protocol import Protocol
from .telemetry import Telemetry, statustext

SLOW_HZ = 1.0
HOME_EVERY = 5                     # slow ticks between two HOME_POSITION
SILENCE_CHECK_S = 1.0
#: the component id of a forwarded UAV's mission events (see StreamServer.companions)
MISSION_COMPONENT = m.MAV_COMP_ID_ONBOARD_COMPUTER
#: the monitor's mission events -> severity; others are INFO
SEVERITY = {"return_low": m.MAV_SEVERITY_WARNING, "forced_landing": m.MAV_SEVERITY_CRITICAL,
            "landed_away": m.MAV_SEVERITY_WARNING, "return_commanded": m.MAV_SEVERITY_NOTICE,
            "landing_commanded": m.MAV_SEVERITY_NOTICE}
#: strategy C's decisions (uavstudy/comm_monitor.py) -> severity: a change of claims is worth a notice
COOP_SEVERITY = {"takeover": m.MAV_SEVERITY_NOTICE, "drop": m.MAV_SEVERITY_NOTICE}
SHORT = {"takeoff": "taking off", "transit": "flying to its targets",
         "return_started": "all targets done, returning", "return_low": "battery 80% used, returning",
         "landing": "landing at the base", "forced_landing": "battery 95% used, landing here",
         "landed_base": "landed at the base", "landed_away": "landed away from the base",
         "return_commanded": "returning (ground station)", "landing_commanded": "landing (ground station)"}


def ticks(t0: float, t1: float, hz: float) -> bool:
    """Does (t0, t1] hold a multiple of 1/hz (simulated time)?"""
    return math.floor(t1 * hz + 1e-9) > math.floor(t0 * hz + 1e-9)


class StreamServer:
    def __init__(self, fleet, links, rate: float, commands, relays=()):
        self.fleet, self.links, self.rate = fleet, links, float(rate)
        self.relays = {f.sysid: link for f, link in zip(fleet.forwarded, relays)}
        self.commands = commands           # callable(vehicle, command, requester, link index)
        self.tm = Telemetry(fleet)
        self.protocol = Protocol(fleet, self.tm)
        self.protocol.relay = self._to_vehicle
        n = len(fleet.vehicles)
        self.removed = np.zeros(n, dtype=bool)
        self.protocol.removed = self.removed
        self.photos = [0] * n
        self.slow_ticks = 0
        self.sent = 0
        self.names = {v.name: v.index for v in fleet.vehicles}
        # a forwarded UAV's mission events: its firmware speaks for the vehicle, so they come from another
        # component of the same system, as from the companion computer that flies the mission (the strategy)
        self.companions = {f.uav: m.MAVLink(None, srcSystem=f.sysid, srcComponent=MISSION_COMPONENT)
                           for f in fleet.forwarded}

    def columns(self, table: bytes) -> dict:
        rows = np.frombuffer(table, dtype=np.float64).reshape(len(COLUMNS), -1)
        return dict(zip(COLUMNS, rows))

    def broadcast(self, messages: list[bytes]) -> None:
        if messages:
            self.sent += len(messages)
            for link in self.links:
                link.send(messages)

    # ------------------------------------------------------------------------------------- records
    def start(self, t: float, table: bytes) -> None:
        cols = self.columns(table)
        self.photos = np.nan_to_num(cols["photos"]).astype(int).tolist()
        self._send(round(t * 1000), cols, True, True, True)

    def tick(self, t0: float, t1: float, table: bytes, events: list, acks: list) -> None:
        t_ms = self.protocol.t_ms = round(t1 * 1000)
        cols = self.columns(table)
        out = self._photos(cols) + self._texts(events) + self._acks(acks)   # a photo before what it ends
        self.broadcast(out)              # packed first, sent first: each vehicle's sequence numbers run on
        slow = ticks(t0, t1, SLOW_HZ)
        if slow:
            self.slow_ticks += 1
        self._send(t_ms, cols, ticks(t0, t1, self.rate), slow, slow and self.slow_ticks % HOME_EVERY == 0)

    def _send(self, t_ms, cols, fast, slow, home) -> None:
        tm, out = self.tm, []
        if fast:
            out += tm.fast(t_ms, cols, self.removed)
        if slow:
            out += tm.slow(t_ms, cols, self.removed, self._mission_seq(cols))
        if home:
            out += [tm.home(k, t_ms) for k in range(len(self.fleet.vehicles))]
        self.broadcast(out)

    def _mission_seq(self, cols) -> list[int]:
        """MISSION_CURRENT: the waypoint of the target being flown to; the return item once going home."""
        seq = []
        for k, v in enumerate(self.fleet.vehicles):
            target, state = cols["target"][k], cols["state"][k]
            if target == target and target >= 0 and int(target) in v.assigned:
                seq.append(1 + v.assigned.index(int(target)))
            elif state == state and STATE_NAMES[int(state)].startswith(("RETURN", "LAND")):
                seq.append(len(v.mission) - 1)
            else:
                seq.append(0)
        return seq

    def _texts(self, events) -> list[bytes]:
        """A STATUSTEXT for each event the monitor emitted (and one for each removal it made)."""
        out = []
        for typ, name, uav, other, detail in events:
            if uav not in self.names and uav not in self.companions:
                continue
            if typ == "mission":
                out.append(self._text(uav, SEVERITY.get(name, m.MAV_SEVERITY_INFO), f"{name}: {SHORT.get(name, '')}"))
            elif typ == "uav":
                for a, b in ((uav, other), (other, uav)):
                    if a in self.names or a in self.companions:
                        out.append(self._text(a, m.MAV_SEVERITY_EMERGENCY, f"collision: with {b}"))
                        out.append(self._removal(a, "UAV-UAV collision"))
            elif typ == "zone":
                out.append(self._text(uav, m.MAV_SEVERITY_EMERGENCY, f"zone_incursion: entered {other}"))
                out.append(self._removal(uav, "zone incursion"))
            elif typ == "coop":       # strategy C: "uav1 took over target 3 of uav2", the detail's short form
                out.append(self._text(uav, COOP_SEVERITY.get(name, m.MAV_SEVERITY_INFO),
                                      f"{uav} {detail.split(' (', 1)[0]}"))
        return out

    def _text(self, uav: str, severity: int, text: str) -> bytes:
        k = self.names.get(uav)
        if k is not None:
            return self.tm.text(k, severity, text)
        return statustext(self.companions[uav], severity, text)

    def _removal(self, uav, why) -> bytes:
        if uav in self.names:
            self.removed[self.names[uav]] = True
        return self._text(uav, m.MAV_SEVERITY_ALERT, f"removed: {why}")

    def _photos(self, cols) -> list[bytes]:
        out = []
        photos, last = cols["photos"], cols["photo_target"]
        for k, v in enumerate(self.fleet.vehicles):
            now = int(photos[k]) if photos[k] == photos[k] else 0
            if now > self.photos[k]:
                self.photos[k] = now
                target = int(last[k]) if last[k] == last[k] else -1
                out.append(self.tm.text(k, m.MAV_SEVERITY_INFO, f"photo: target {target} ({now}/{len(v.assigned)})"))
                if target in v.assigned:
                    out.append(self.tm.reached(k, 1 + v.assigned.index(target)))
        return out

    def _acks(self, acks) -> list[bytes]:
        """COMMAND_ACK (with the step's other messages, in packing order; its target fields say for whom)."""
        out = []
        for k, command, requester, what, taken in acks:
            enc = self.tm.enc[k]
            out.append(packed(enc, enc.command_ack_encode(
                command, m.MAV_RESULT_ACCEPTED if taken else m.MAV_RESULT_DENIED, 0, 0, *requester)))
            out.append(self.tm.text(k, m.MAV_SEVERITY_NOTICE, f"command: {what} {'accepted' if taken else 'denied'}"))
        return out

    # ------------------------------------------------------------------------------------- the links
    def _to_vehicle(self, sysid, data: bytes) -> bool:
        """A ground station's message for a forwarded vehicle goes to it as it is."""
        link = self.relays.get(sysid)
        if link is None:
            return False
        link.send([data])
        return True

    def poll(self) -> None:
        for link in self.relays.values():     # a forwarded vehicle's own stream, to every ground station
            for _peer, data in link.receive():
                self.broadcast([data])
        for link in self.links:
            for _peer, data in link.receive():
                self.protocol.feed(link, data)
        for c in self.protocol.commands:
            self.commands(c.vehicle, c.command, c.requester, self.links.index(c.link))
        self.protocol.commands = []

    def stats(self) -> dict:
        p = self.protocol
        return {"messages_sent": self.sent, "datagrams_dropped": sum(ln.dropped for ln in self.links),
                "downloads": p.downloads(), **({"unsupported": p.unsupported} if p.unsupported else {})}

    def close(self) -> None:
        for link in self.links + list(self.relays.values()):
            link.close()


def serve(server: StreamServer, conn) -> None:
    """The streaming process's loop (see the module docstring); returns when the simulation is done."""
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)      # the simulation ends this process, by closing its pipe
    checked = time.monotonic()
    try:
        while True:
            links = server.links + list(server.relays.values())
            ready = wait([conn] + [fd for ln in links for fd in ln.filenos()], timeout=SILENCE_CHECK_S)
            if conn in ready:
                while conn.poll():
                    record = conn.recv()
                    if record[0] == "ticks":
                        for tick in record[1]:
                            server.tick(*tick)
                    elif record[0] == "start":
                        server.start(*record[1:])
                    elif record[0] == "stop":
                        server.poll()
                        conn.send(("stats", server.stats()))
                        return
            server.poll()
            now = time.monotonic()
            if now - checked >= SILENCE_CHECK_S:
                checked = now
                for link in server.links:
                    link.check_silence()
    except (EOFError, OSError):
        return                                 # the simulation is gone
    finally:
        server.close()
