"""What a ground station asks of a vehicle, answered as the MAVLink protocols say (mavlink.io/en/services).

* Mission protocol, download only: MISSION_REQUEST_LIST -> MISSION_COUNT, MISSION_REQUEST_INT (or the
  older MISSION_REQUEST) -> MISSION_ITEM_INT (MISSION_ITEM), the ground station's MISSION_ACK ends the
  transfer.  ``MISSION_TYPE_MISSION`` is the UAV's plan, ``MISSION_TYPE_FENCE`` the restricted zones as
  exclusion polygons, ``MISSION_TYPE_RALLY`` is empty.  An upload or a clear is refused with
  MISSION_ACK ``MAV_MISSION_UNSUPPORTED`` (the plan is the scenario's).
* Commands (COMMAND_LONG, COMMAND_INT): MAV_CMD_NAV_RETURN_TO_LAUNCH and MAV_CMD_NAV_LAND are handed to
  the run (``Commands``) and acknowledged once the strategy has taken them; requests for HOME_POSITION and
  AUTOPILOT_VERSION are answered at once; any other command gets COMMAND_ACK ``MAV_RESULT_UNSUPPORTED``.
* Parameters: the vehicle has one, SYSID_THISMAV (ground stations read the parameters before they show a
  vehicle as ready).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as m

from .frames import packed

APPLIED = (m.MAV_CMD_NAV_RETURN_TO_LAUNCH, m.MAV_CMD_NAV_LAND)
CAPABILITIES = (m.MAV_PROTOCOL_CAPABILITY_MISSION_INT | m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                | m.MAV_PROTOCOL_CAPABILITY_COMMAND_INT | m.MAV_PROTOCOL_CAPABILITY_MAVLINK2)
MISSION_TYPES = {m.MAV_MISSION_TYPE_MISSION: "mission", m.MAV_MISSION_TYPE_FENCE: "fence",
                 m.MAV_MISSION_TYPE_RALLY: "rally"}


@dataclass
class Command:
    """A command to apply at the next step, and whom to acknowledge."""
    vehicle: int
    command: int
    requester: tuple[int, int]
    link: object
    applied_at: float | None = None


@dataclass
class Transfer:
    uav: str
    mission_type: str
    count: int
    sent: set = field(default_factory=set)
    acked: bool = False


class Protocol:
    def __init__(self, fleet, telemetry):
        self.fleet, self.tm = fleet, telemetry
        self.by_sysid = {v.sysid: v.index for v in fleet.vehicles}
        self.commands: list[Command] = []          # waiting for the next step
        self.transfers: dict[tuple, Transfer] = {}
        self.unsupported: dict[str, int] = {}
        self.parsers: dict[int, m.MAVLink] = {}
        self.removed = None                        # set by the stream: which vehicles were taken out
        self.relay = lambda sysid, data: False     # a forwarded vehicle's messages go to it (forward.py)
        self.t_ms = 0

    # ------------------------------------------------------------------------------------- input
    def feed(self, link, data: bytes) -> None:
        parser = self.parsers.get(id(link))
        if parser is None:
            parser = self.parsers[id(link)] = m.MAVLink(None)
            parser.robust_parsing = True
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:  # noqa: BLE001 - a garbled message from outside must not end the run
            return
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                continue
            target = getattr(msg, "target_system", None)
            if target and self.relay(target, msg.get_msgbuf()):
                continue
            k = self.by_sysid.get(target)
            if k is not None:
                self._handle(link, k, msg)

    def _handle(self, link, k, msg) -> None:
        typ = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        enc = self.tm.enc[k]

        def reply(message):
            link.send([packed(enc, message)])
        if typ == "MISSION_REQUEST_LIST":
            items = self._items(k, msg.mission_type)
            key = (id(link), src, k, msg.mission_type)
            self.transfers[key] = Transfer(self.fleet.vehicles[k].name, MISSION_TYPES.get(msg.mission_type, "?"),
                                           len(items))
            reply(enc.mission_count_encode(src[0], src[1], len(items), msg.mission_type))
        elif typ in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            items = self._items(k, msg.mission_type)
            if not 0 <= msg.seq < len(items):
                reply(enc.mission_ack_encode(src[0], src[1], m.MAV_MISSION_INVALID_SEQUENCE, msg.mission_type))
                return
            it = items[msg.seq]
            args = (src[0], src[1], msg.seq, it["frame"], it["command"], 0, 1, it.get("param1", 0.0), 0.0, 0.0, 0.0)
            if typ == "MISSION_REQUEST_INT":
                reply(enc.mission_item_int_encode(*args, it["x"], it["y"], it["z"], msg.mission_type))
            else:
                frame = {m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: m.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                         m.MAV_FRAME_GLOBAL_INT: m.MAV_FRAME_GLOBAL}.get(it["frame"], it["frame"])
                reply(enc.mission_item_encode(src[0], src[1], msg.seq, frame, *args[4:], it["x"] * 1e-7,
                                              it["y"] * 1e-7, it["z"], msg.mission_type))
            tr = self.transfers.get((id(link), src, k, msg.mission_type))
            if tr is not None:
                tr.sent.add(msg.seq)
        elif typ == "MISSION_ACK":
            tr = self.transfers.get((id(link), src, k, msg.mission_type))
            if tr is not None and msg.type == m.MAV_MISSION_ACCEPTED:
                tr.acked = True
        elif typ in ("MISSION_COUNT", "MISSION_CLEAR_ALL", "MISSION_WRITE_PARTIAL_LIST"):
            reply(enc.mission_ack_encode(src[0], src[1], m.MAV_MISSION_UNSUPPORTED, msg.mission_type))
            self._count_unsupported(typ)
        elif typ in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ"):
            reply(enc.param_value_encode(b"SYSID_THISMAV", float(self.fleet.vehicles[k].sysid),
                                         m.MAV_PARAM_TYPE_REAL32, 1, 0))
        elif typ in ("COMMAND_LONG", "COMMAND_INT"):
            self._command(link, k, msg, src, reply)

    def _items(self, k, mission_type) -> list[dict]:
        if mission_type == m.MAV_MISSION_TYPE_MISSION:
            return self.fleet.vehicles[k].mission
        if mission_type == m.MAV_MISSION_TYPE_FENCE:
            return self.fleet.fence
        return []

    def _command(self, link, k, msg, src, reply) -> None:
        cmd, enc = msg.command, self.tm.enc[k]

        def ack(result):
            reply(enc.command_ack_encode(cmd, result, 0, 0, src[0], src[1]))
        if cmd in APPLIED:
            v = self.fleet.vehicles[k]
            if v.command_input is None:
                ack(m.MAV_RESULT_UNSUPPORTED)     # a strategy without the ground-station input
            elif self.removed is not None and self.removed[k]:
                ack(m.MAV_RESULT_DENIED)
            else:
                self.commands.append(Command(k, cmd, src, link))
            return
        wanted = int(msg.param1) if cmd == m.MAV_CMD_REQUEST_MESSAGE else None
        if cmd == m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES or wanted == m.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            reply(enc.autopilot_version_encode(CAPABILITIES, 0, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0,
                                               self.fleet.vehicles[k].sysid))
            ack(m.MAV_RESULT_ACCEPTED)
        elif cmd == m.MAV_CMD_GET_HOME_POSITION or wanted == m.MAVLINK_MSG_ID_HOME_POSITION:
            link.send([self.tm.home(k, self.t_ms)])
            ack(m.MAV_RESULT_ACCEPTED)
        else:
            ack(m.MAV_RESULT_UNSUPPORTED)
            self._count_unsupported(f"command {cmd}")

    def _count_unsupported(self, what: str) -> None:
        self.unsupported[what] = self.unsupported.get(what, 0) + 1

    def downloads(self) -> list[dict]:
        return [{"uav": tr.uav, "type": tr.mission_type, "items": tr.count, "items_sent": len(tr.sent),
                 "acknowledged": tr.acked} for tr in self.transfers.values()]
