"""The conversation a careful ground station holds with one ArduCopter, as a state machine driven by time.

``GroundStation`` never blocks and never reads a clock: the caller feeds it the bytes the vehicle sent
(:meth:`feed`) and calls :meth:`update` with the vehicle's (simulated) time, and it returns the bytes to send.
That makes it usable in lock-step (the firmware only runs between our calls) and in paced mode alike, and
testable against a fake peer.  Stages::

    connect -> configure -> wait_position -> ready          (get-ready: heartbeat, streams, EKF, pre-arm)
    ready -- takeoff(alt) --> guided -> arming -> takeoff -> flying -- land() --> landing -> landed

* connect: wait for the vehicle's HEARTBEAT (our own heartbeat goes out at 1 Hz from the start; the firmware
  starts STATUSTEXT only after the first packet from a ground station).
* configure: SET_MESSAGE_INTERVAL (MAV_CMD_SET_MESSAGE_INTERVAL) for each stream we read, re-sent until acked
  (or, with ``configure_at``, all of them at those fixed vehicle times: lock-step's determinism).
* wait_position: the EKF reports attitude, velocity and absolute position without constant-position mode,
  the GPS has a 3D fix, HOME_POSITION is known and, when the firmware reports it, SYS_STATUS says the
  pre-arm checks pass.  Arming earlier is refused ("Need Position Estimate", "AHRS: waiting for home").
* guided, arming, takeoff: DO_SET_MODE GUIDED, then COMPONENT_ARM_DISARM every ``arm_retry`` s until accepted
  (refusals come as COMMAND_ACK plus a STATUSTEXT reason; more than ``arm_timeout`` s of refusals is a
  LinkError quoting the last reason), then NAV_TAKEOFF right away (the firmware disarms 10 s after arming on
  the ground).
* flying: :meth:`goto` sends SET_POSITION_TARGET_GLOBAL_INT (position only, altitude relative to home) when
  the set-point changes, and only then: the link is TCP, a GUIDED position target does not time out, and
  the firmware plans its path to the target from its current state, so a repeat adds nothing
  (``goto_repeat`` > 0 re-sends it every that many s, as some ground stations do).
* landing: DO_SET_MODE LAND; landed when EXTENDED_SYS_STATE says on ground and the HEARTBEAT says disarmed.

No HEARTBEAT for ``heartbeat_timeout`` s of vehicle time raises LinkError in every stage.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

__all__ = ["GroundStation", "LinkError", "STREAMS", "COPTER_MODES", "GUIDED", "LAND"]

GUIDED, LAND = 4, 9
COPTER_MODES = {0: "STABILIZE", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL", 9: "LAND"}
#: message id -> rate (Hz) requested with SET_MESSAGE_INTERVAL
STREAMS = {
    mav.MAVLINK_MSG_ID_SYS_STATUS: 2.0,
    mav.MAVLINK_MSG_ID_SYSTEM_TIME: 10.0,
    mav.MAVLINK_MSG_ID_GPS_RAW_INT: 2.0,
    mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 2.0,
    mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 4.0,
    mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0,
    mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 10.0,
    mav.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
}
EKF_NEEDED = (mav.EKF_ATTITUDE | mav.EKF_VELOCITY_HORIZ | mav.EKF_VELOCITY_VERT | mav.EKF_POS_HORIZ_ABS
              | mav.EKF_POS_VERT_ABS)
EKF_BAD = mav.EKF_CONST_POS_MODE | mav.EKF_UNINITIALIZED | mav.EKF_GPS_GLITCHING
PREARM = mav.MAV_SYS_STATUS_PREARM_CHECK
POSITION_ONLY = 0b110111111000     # type_mask: ignore velocity, acceleration, yaw and yaw rate
ACCEPTED = mav.MAV_RESULT_ACCEPTED
STAGES = ("connect", "configure", "wait_position", "ready", "guided", "arming", "takeoff", "flying", "landing",
          "landed")


class LinkError(RuntimeError):
    """The vehicle went silent or refused what the mission needs (one-line reason)."""


class GroundStation:
    def __init__(self, *, target_system: int = 1, streams: dict | None = None, heartbeat_timeout: float = 5.0,
                 arm_retry: float = 1.0, arm_timeout: float = 30.0, command_retry: float = 1.0,
                 goto_repeat: float | None = None, source_system: int = 255, source_component: int = 190,
                 configure_at: tuple = ()):
        self.mav = mav.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        self.mav.robust_parsing = True
        self.target = int(target_system)
        self.streams = dict(STREAMS if streams is None else streams)
        self.heartbeat_timeout = heartbeat_timeout
        self.arm_retry, self.arm_timeout = arm_retry, arm_timeout
        self.command_retry, self.goto_repeat = command_retry, goto_repeat
        self.stage = "connect"
        self.configure_at = tuple(configure_at)
        self._configured_at: set = set()
        self._out: list[bytes] = []
        self.now = 0.0
        # what the vehicle told us
        self.last_heartbeat: float | None = None
        self.armed = False
        self.custom_mode = -1
        self.landed_state = mav.MAV_LANDED_STATE_UNDEFINED
        self.ekf_flags = 0
        self.gps_fix = 0
        self.home = None                     # (lat, lon, alt) deg, deg, m
        self.prearm_ok: bool | None = None   # None: the firmware does not report it
        self.boot_ms: int | None = None      # vehicle clock of the newest timestamped message
        self.position = None                 # GLOBAL_POSITION_INT: (lat, lon, alt_msl, relative_alt) deg/m
        self.local = None                    # LOCAL_POSITION_NED (x, y, z, vx, vy, vz) m, m/s
        self.statustext: list[tuple[float, str]] = []
        self.acks: dict[int, int] = {}       # command -> last result
        # our pending actions
        self._acked_streams: set[int] = set()
        self._next_hb = 0.0
        self._next_cmd: dict[str, float] = {}
        self._arm_since: float | None = None
        self._arm_refusal = ""
        self._takeoff_alt = 0.0
        self._goto = None
        self._goto_sent_at = -1e9
        self._goto_sent = None
        self._first_packet = True
        self._pending: list = []
        self._t0: float | None = None
        self._pending_stream: int | None = None

    # ------------------------------------------------------------------ input
    def feed(self, data: bytes, cut_ms: int | None = None) -> None:
        """Bytes received from the vehicle, in stream order.

        With ``cut_ms`` (lock-step), only the messages up to the last one stamped (``time_boot_ms``) at or before
        ``cut_ms`` are taken now, the rest at a later call: a message is taken once a stamped one that follows
        it is, so what the ground station has seen at a given vehicle time is fixed by the firmware's byte
        stream alone, not by when the bytes happened to reach our socket."""
        if data:
            self._pending.extend(self.mav.parse_buffer(data) or [])
            while True:                    # parse_buffer returns what one call could complete
                more = self.mav.parse_char(b"")
                if more is None:
                    break
                self._pending.append(more)
        if cut_ms is None:
            take = len(self._pending)
        else:
            take = 0
            for i, m in enumerate(self._pending):
                stamp = getattr(m, "time_boot_ms", None)
                if stamp is not None:
                    if stamp > cut_ms:
                        break
                    take = i + 1
        msgs, self._pending = self._pending[:take], self._pending[take:]
        for m in msgs:
            self._handle(m)

    def _handle(self, m) -> None:
        t = m.get_type()
        if m.get_srcSystem() != self.target and t != "BAD_DATA":
            return
        if hasattr(m, "time_boot_ms"):
            self.boot_ms = int(m.time_boot_ms)
        if t == "HEARTBEAT":
            if m.get_srcComponent() != mav.MAV_COMP_ID_AUTOPILOT1 or m.type == mav.MAV_TYPE_GCS:
                return
            self.last_heartbeat = self.now
            self.armed = bool(m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
            self.custom_mode = int(m.custom_mode)
        elif t == "COMMAND_ACK":
            self.acks[int(m.command)] = int(m.result)
        elif t == "STATUSTEXT":
            self.statustext.append((self.now, m.text.rstrip("\0")))
            del self.statustext[:-20]
        elif t == "EKF_STATUS_REPORT":
            self.ekf_flags = int(m.flags)
        elif t == "GPS_RAW_INT":
            self.gps_fix = int(m.fix_type)
        elif t == "HOME_POSITION":
            self.home = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
        elif t == "SYS_STATUS":
            if m.onboard_control_sensors_present & PREARM:
                self.prearm_ok = bool(m.onboard_control_sensors_health & PREARM)
        elif t == "EXTENDED_SYS_STATE":
            self.landed_state = int(m.landed_state)
        elif t == "GLOBAL_POSITION_INT":
            self.position = (m.lat * 1e-7, m.lon * 1e-7, m.alt * 1e-3, m.relative_alt * 1e-3)
        elif t == "LOCAL_POSITION_NED":
            self.local = (m.x, m.y, m.z, m.vx, m.vy, m.vz)

    # ------------------------------------------------------------------ derived state
    @property
    def ekf_ok(self) -> bool:
        return (self.ekf_flags & EKF_NEEDED) == EKF_NEEDED and not self.ekf_flags & EKF_BAD

    @property
    def position_ok(self) -> bool:
        return self.ekf_ok and self.gps_fix >= 3 and self.home is not None and self.prearm_ok is not False

    @property
    def mode_name(self) -> str:
        return COPTER_MODES.get(self.custom_mode, str(self.custom_mode))

    @property
    def ready(self) -> bool:
        return STAGES.index(self.stage) >= STAGES.index("ready")

    def last_reason(self) -> str:
        return self.statustext[-1][1] if self.statustext else ""

    # ------------------------------------------------------------------ requests from the vehicle component
    def takeoff(self, altitude: float) -> None:
        """GUIDED, arm, take off to ``altitude`` m above home (from ready or landed)."""
        if self.stage in ("ready", "landed"):
            self._takeoff_alt = float(altitude)
            self.stage = "guided"
            self._next_cmd.clear()
            self.acks.pop(mav.MAV_CMD_DO_SET_MODE, None)

    def goto(self, lat: float, lon: float, rel_alt: float) -> None:
        self._goto = (float(lat), float(lon), float(rel_alt))

    def land(self) -> None:
        if self.stage in ("guided", "arming", "takeoff", "flying"):
            self.stage = "landing"
            self._next_cmd.clear()
            self.acks.pop(mav.MAV_CMD_DO_SET_MODE, None)

    def set_param(self, name: str, value: float) -> None:
        """PARAM_SET (fire and forget: the firmware echoes PARAM_VALUE)."""
        self._send(mav.MAVLink_param_set_message(self.target, 1, name.encode("ascii"), float(value),
                                                 mav.MAV_PARAM_TYPE_REAL32))

    # ------------------------------------------------------------------ output
    def _send(self, msg) -> None:
        self._out.append(msg.pack(self.mav))

    def _command(self, key: str, command: int, *params, every: float | None = None) -> None:
        """Send COMMAND_LONG ``command`` now and again every ``every`` s until its ack arrives."""
        if self.now < self._next_cmd.get(key, -1.0):
            return
        p = list(params) + [0.0] * (7 - len(params))
        self._send(mav.MAVLink_command_long_message(self.target, 1, command, 0, *p))
        self._next_cmd[key] = self.now + (every or self.command_retry)

    def update(self, now: float) -> bytes:
        """Advance the conversation to vehicle time ``now`` (s); returns the bytes to send to the vehicle."""
        self.now = float(now)
        if self.now >= self._next_hb or self._first_packet:
            self._first_packet = False
            self._send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
            self._next_hb = self.now + 1.0
        if self._t0 is None:
            self._t0 = self.now
        if self.last_heartbeat is None:
            if self.now - self._t0 > self.heartbeat_timeout:
                raise LinkError(f"no HEARTBEAT from the vehicle within {self.heartbeat_timeout:g} s of vehicle time")
        elif self.now - self.last_heartbeat > self.heartbeat_timeout:
            raise LinkError(f"no HEARTBEAT for {self.now - self.last_heartbeat:.1f} s of vehicle time "
                            f"(stage {self.stage})")
        getattr(self, f"_stage_{self.stage}")()
        out, self._out = b"".join(self._out), []
        return out

    def _stage_connect(self):
        if self.last_heartbeat is not None or self.configure_at:
            self.stage = "configure"
            self._stage_configure()

    def _stage_configure(self):
        if self.configure_at:
            self._configure_blind()
            return
        if self._pending_stream is not None and self.acks.pop(mav.MAV_CMD_SET_MESSAGE_INTERVAL, None) is not None:
            self._acked_streams.add(self._pending_stream)     # refused streams are not asked for again
            self._pending_stream = None
            self._next_cmd.pop("interval", None)
        missing = [mid for mid in self.streams if mid not in self._acked_streams]
        if not missing:
            self.stage = "wait_position"
            self._stage_wait_position()
            return
        self._pending_stream = missing[0]
        self._command("interval", mav.MAV_CMD_SET_MESSAGE_INTERVAL, float(missing[0]), 1e6 / self.streams[missing[0]])

    def _configure_blind(self):
        """Lock-step: every stream request goes out at the fixed vehicle times ``configure_at`` whatever the
        acks say, so that the firmware's stream schedule (and what the ground station later sees when) does not
        depend on when acks reached us; at least one must have been accepted by the last of them."""
        due = [t for t in self.configure_at if t <= self.now and t not in self._configured_at]
        if due:
            self._configured_at.update(due)
            for mid, rate in self.streams.items():
                self._send(mav.MAVLink_command_long_message(self.target, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                                            float(mid), 1e6 / rate, 0, 0, 0, 0, 0))
        if len(self._configured_at) == len(self.configure_at) and self.now > max(self.configure_at):
            if self.acks.get(mav.MAV_CMD_SET_MESSAGE_INTERVAL) is None:
                raise LinkError(f"no SET_MESSAGE_INTERVAL acknowledged by {self.now:.1f} s of vehicle time")
            self.stage = "wait_position"

    def _stage_wait_position(self):
        if self.position_ok:
            self.stage = "ready"

    def _stage_ready(self):
        pass

    def _stage_guided(self):
        if self.custom_mode == GUIDED and self.acks.get(mav.MAV_CMD_DO_SET_MODE) == ACCEPTED:
            self.stage = "arming"
            self._arm_since = self.now
            self.acks.pop(mav.MAV_CMD_COMPONENT_ARM_DISARM, None)
            self._stage_arming()
            return
        self._command("mode", mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)

    def _stage_arming(self):
        res = self.acks.pop(mav.MAV_CMD_COMPONENT_ARM_DISARM, None)
        if res == ACCEPTED:
            self.stage = "takeoff"
            self.acks.pop(mav.MAV_CMD_NAV_TAKEOFF, None)
            self._stage_takeoff()
            return
        if res is not None:
            self._arm_refusal = self.last_reason() or f"COMMAND_ACK result {res}"
        if self.now - self._arm_since > self.arm_timeout:
            raise LinkError(f"arming refused for {self.now - self._arm_since:.1f} s of vehicle time: "
                            f"{self._arm_refusal or 'no answer'}")
        self._command("arm", mav.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, every=self.arm_retry)

    def _stage_takeoff(self):
        res = self.acks.get(mav.MAV_CMD_NAV_TAKEOFF)
        if res == ACCEPTED:
            self.stage = "flying"
            self._goto_sent = None
            self._stage_flying()
            return
        if res is not None:
            raise LinkError(f"takeoff refused (COMMAND_ACK result {res}): {self.last_reason()}")
        self._command("takeoff", mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, self._takeoff_alt)

    def _stage_flying(self):
        g = self._goto
        if g is None:
            return
        if g != self._goto_sent or (self.goto_repeat and self.now - self._goto_sent_at >= self.goto_repeat):
            lat, lon, alt = g
            self._send(mav.MAVLink_set_position_target_global_int_message(
                int(round(self.now * 1000.0)) & 0xFFFFFFFF, self.target, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                POSITION_ONLY, int(round(lat * 1e7)), int(round(lon * 1e7)), alt, 0, 0, 0, 0, 0, 0, 0, 0))
            self._goto_sent, self._goto_sent_at = g, self.now

    def _stage_landing(self):
        if self.custom_mode != LAND:
            self._command("land", mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, LAND)
        if not self.armed and self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND:
            self.stage = "landed"

    def _stage_landed(self):
        pass
