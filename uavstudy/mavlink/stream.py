"""The UAV fleet as live MAVLink vehicles: an observer that streams, a manipulator that takes commands.

``VehicleStream`` (observer, after the UAV monitor): after every master step it sends each vehicle's
GLOBAL_POSITION_INT and ATTITUDE at ``rate`` per simulated second, HEARTBEAT, VFR_HUD, SYS_STATUS,
BATTERY_STATUS, EXTENDED_SYS_STATE and MISSION_CURRENT once a simulated second, HOME_POSITION every 5 s,
a STATUSTEXT for every event the monitor emitted in the step (and for every photo, with
MISSION_ITEM_REACHED), and the COMMAND_ACK of the commands applied in the step.

``CommandInput`` (manipulator): before every step it reads what the ground stations sent (answering
mission downloads and requests at once) and writes a return or land command into the UAV strategy's
``command`` input, which the strategy takes in this step; the input goes back to 0 before the next one,
so that a repeated command is a change again.  Applied commands are events (type ``command``) in
events.csv, with the result the ground station was told.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import common as m

from master.manipulators import Manipulator
from master.observers import Observer
from uavsim.strategy import COMMAND_LAND, COMMAND_NONE, COMMAND_RETURN, LAND_CMD, RETURN_CMD, STATE_NAMES

from ..names import MISSION_DETAIL
from .frames import packed
from .protocol import Protocol
from .telemetry import Telemetry

SLOW_HZ = 1.0
HOME_EVERY = 5                     # slow ticks between two HOME_POSITION
#: MAVLink command -> (value of the strategy's command input, mission state that shows it taken, event name)
COMMANDS = {m.MAV_CMD_NAV_RETURN_TO_LAUNCH: (COMMAND_RETURN, RETURN_CMD, "return_to_launch"),
            m.MAV_CMD_NAV_LAND: (COMMAND_LAND, LAND_CMD, "land")}
#: the monitor's mission events -> (severity, short text); others are INFO with their name
SEVERITY = {"return_low": m.MAV_SEVERITY_WARNING, "forced_landing": m.MAV_SEVERITY_CRITICAL,
            "landed_away": m.MAV_SEVERITY_WARNING, "return_commanded": m.MAV_SEVERITY_NOTICE,
            "landing_commanded": m.MAV_SEVERITY_NOTICE}
SHORT = {"takeoff": "taking off", "transit": "flying to its targets",
         "return_started": "all targets done, returning", "return_low": "battery 80% used, returning",
         "landing": "landing at the base", "forced_landing": "battery 95% used, landing here",
         "landed_base": "landed at the base", "landed_away": "landed away from the base",
         "return_commanded": "returning (ground station)", "landing_commanded": "landing (ground station)"}


def _ticks(t0: float, t1: float, hz: float) -> bool:
    """Does (t0, t1] hold a multiple of 1/hz (simulated time)?"""
    return math.floor(t1 * hz + 1e-9) > math.floor(t0 * hz + 1e-9)


class Hub:
    """What the observer and the manipulator share: the links, the fleet, the encoders, the protocol."""

    def __init__(self, fleet, links, rate: float):
        self.fleet, self.links, self.rate = fleet, links, float(rate)
        self.tm = Telemetry(fleet)
        self.protocol = Protocol(fleet, self.tm)
        self.sent = 0
        self.applied: list = []              # commands written into the inputs before this step

    def poll(self) -> None:
        for link in self.links:
            for _peer, data in link.receive():
                self.protocol.feed(link, data)

    def broadcast(self, messages: list[bytes]) -> None:
        if messages:
            self.sent += len(messages)
            for link in self.links:
                link.send(messages)

    def close(self) -> None:
        for link in self.links:
            link.close()


class CommandInput(Manipulator):
    name = "mavlink-commands"

    def __init__(self, hub: Hub):
        self.hub = hub
        self.to_reset: list[str] = []

    def before_step(self, n: int, t: float) -> None:
        hub = self.hub
        hub.poll()
        for q in self.to_reset:
            self.ctx.set_value(q, COMMAND_NONE)
        self.to_reset = []
        waiting = hub.protocol.commands
        if not waiting:
            return
        hub.protocol.commands = []
        for c in waiting:
            q = hub.fleet.vehicles[c.vehicle].command_input
            self.ctx.set_value(q, COMMANDS[c.command][0])
            c.applied_at = t
            if q not in self.to_reset:
                self.to_reset.append(q)
            hub.applied.append(c)


class VehicleStream(Observer):
    name = "mavlink"

    def __init__(self, hub: Hub, monitor):
        self.hub, self.monitor = hub, monitor
        self.events_seen = 0
        self.slow_ticks = 0
        self.commands: list[dict] = []
        self.attached = False

    def required_variables(self) -> list[str]:
        return self.hub.fleet.required_variables()

    def attach(self, ctx, start: float) -> None:
        super().attach(ctx, start)
        fleet = self.hub.fleet
        fleet.attach(ctx)
        n = len(fleet.vehicles)
        self.removed = np.zeros(n, dtype=bool)
        self.hub.protocol.removed = self.removed
        cols = fleet.read()
        self.photos = np.nan_to_num(cols["photos"]).astype(int).tolist()
        self.events_seen = len(ctx.events)
        self.attached = True
        t_ms = int(round(start * 1000))
        self._send(t_ms, cols, fast=True, slow=True, home=True)

    def _mission_seq(self, cols) -> list[int]:
        """MISSION_CURRENT: the waypoint of the target being flown to; the return item once going home."""
        seq = []
        for k, v in enumerate(self.hub.fleet.vehicles):
            target, state = cols["target"][k], cols["state"][k]
            if target == target and target >= 0 and int(target) in v.assigned:
                seq.append(1 + v.assigned.index(int(target)))
            elif state == state and STATE_NAMES[int(state)].startswith(("RETURN", "LAND")):
                seq.append(len(v.mission) - 1)
            else:
                seq.append(0)
        return seq

    def _send(self, t_ms, cols, fast, slow, home) -> None:
        tm, out = self.hub.tm, []
        if fast:
            out += tm.fast(t_ms, cols, self.removed)
        if slow:
            out += tm.slow(t_ms, cols, self.removed, self._mission_seq(cols))
        if home:
            out += [tm.home(k, t_ms) for k in range(len(self.hub.fleet.vehicles))]
        self.hub.broadcast(out)

    def after_step(self, n: int, t0: float, t1: float) -> None:
        hub = self.hub
        t_ms = hub.protocol.t_ms = int(round(t1 * 1000))
        fast = _ticks(t0, t1, hub.rate)
        slow = _ticks(t0, t1, SLOW_HZ)
        events = len(self.ctx.events) > self.events_seen
        if not (fast or slow or events or hub.applied):
            return
        cols = hub.fleet.read()
        texts = self._photos(cols) + (self._texts() if events else [])     # a photo comes before what it ends
        if hub.applied:
            texts += self._acknowledge(cols, t0)
        if slow:
            self.slow_ticks += 1
            if self.slow_ticks % 60 == 0:
                for link in hub.links:
                    link.check_silence()
        hub.broadcast(texts)            # packed first: sent first, so each vehicle's sequence numbers run on
        self._send(t_ms, cols, fast, slow, slow and self.slow_ticks % HOME_EVERY == 0)

    # ----------------------------------------------------------------------------------------- events
    def _texts(self) -> list[bytes]:
        """A STATUSTEXT for each event the monitor emitted since the last step."""
        events = self.ctx.events
        new, self.events_seen = events[self.events_seen:], len(events)
        index = {v.name: v.index for v in self.hub.fleet.vehicles}
        tm, out = self.hub.tm, []
        for e in new:
            typ, name = e.get("type"), e.get("event")
            k = index.get(e.get("uav"))
            if k is None or typ == "command":
                continue
            if typ == "mission":
                out.append(tm.text(k, SEVERITY.get(name, m.MAV_SEVERITY_INFO), f"{name}: {SHORT.get(name, '')}"))
            elif typ == "uav":
                other = e.get("other")
                for a, b in ((k, other), (index.get(other), e.get("uav"))):
                    if a is not None:
                        out.append(tm.text(a, m.MAV_SEVERITY_EMERGENCY, f"collision: with {b}"))
                        out.append(self._removal(a, "UAV-UAV collision"))
            elif typ == "zone":
                out.append(tm.text(k, m.MAV_SEVERITY_EMERGENCY, f"zone_incursion: entered {e.get('other')}"))
                out.append(self._removal(k, "zone incursion"))
        return out

    def _removal(self, k, why) -> bytes:
        self.removed[k] = True
        return self.hub.tm.text(k, m.MAV_SEVERITY_ALERT, f"removed: {why}")

    def _photos(self, cols) -> list[bytes]:
        out = []
        photos, last = cols["photos"], cols["photo_target"]
        for k, v in enumerate(self.hub.fleet.vehicles):
            now = int(photos[k]) if photos[k] == photos[k] else 0
            if now > self.photos[k]:
                self.photos[k] = now
                target = int(last[k]) if last[k] == last[k] else -1
                out.append(self.hub.tm.text(k, m.MAV_SEVERITY_INFO,
                                            f"photo: target {target} ({now}/{len(v.assigned)})"))
                if target in v.assigned:
                    out.append(self.hub.tm.reached(k, 1 + v.assigned.index(target)))
        return out

    def _acknowledge(self, cols, t0) -> list[bytes]:
        """COMMAND_ACK of the commands the strategy got in this step: accepted if it shows them taken."""
        hub, out = self.hub, []
        for c in hub.applied:
            code, state_taken, what = COMMANDS[c.command]
            v = hub.fleet.vehicles[c.vehicle]
            state = cols["state"][c.vehicle]
            taken = state == state and int(state) == state_taken
            result = m.MAV_RESULT_ACCEPTED if taken else m.MAV_RESULT_DENIED
            enc = hub.tm.enc[c.vehicle]
            # with the step's other messages (in the order they were packed); its target fields say for whom
            out.append(packed(enc, enc.command_ack_encode(c.command, result, 0, 0, *c.requester)))
            now = STATE_NAMES[int(state)] if state == state else "unknown"
            detail = (MISSION_DETAIL.get(state_taken, "") if taken
                      else f"refused by the strategy in state {now}")
            x, y, z = (float(cols[a][c.vehicle]) for a in ("x", "y", "z"))
            lat, lon, alt = hub.fleet.geodetic(*(cols[a][c.vehicle:c.vehicle + 1] for a in ("x", "y", "z")))[0]
            event = {"time": round(float(t0), 9), "type": "command", "event": what, "uav": v.name,
                     "other": f"gcs {c.requester[0]}/{c.requester[1]} via {c.link.url}", "x": x, "y": y, "z": z,
                     "lat": lat, "lon": lon, "alt": alt, "distance": None,
                     "consumed": float(cols["consumed"][c.vehicle]),
                     "detail": ("accepted: " if taken else "denied: ") + detail}
            self.ctx.emit(event)
            self.events_seen += 1           # our own event: no STATUSTEXT of the monitor's kind
            self.commands.append({"time": event["time"], "uav": v.name, "command": what,
                                  "result": "accepted" if taken else "denied"})
            out.append(hub.tm.text(c.vehicle, m.MAV_SEVERITY_NOTICE,
                                   f"command: {what} {'accepted' if taken else 'denied'}"))
        hub.applied = []
        return out

    def finish(self, out_dir, outcome) -> dict:
        hub = self.hub
        hub.close()
        p = hub.protocol
        return {"vehicles": len(hub.fleet.vehicles), "links": [ln.url for ln in hub.links],
                "messages_sent": hub.sent, "datagrams_dropped": sum(ln.dropped for ln in hub.links),
                "downloads": p.downloads(), "commands": self.commands,
                **({"unsupported": p.unsupported} if p.unsupported else {})}
