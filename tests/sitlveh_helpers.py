"""Helpers of the SITL vehicle tests: the binary (or why it is absent), a fake ArduCopter MAVLink peer."""
from __future__ import annotations

import os
import select
import socket
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO / "fmu_sources") not in sys.path:     # sitlsim is bundled into the FMU, not necessarily installed
    sys.path.append(str(REPO / "fmu_sources"))

from pymavlink.dialects.v20 import ardupilotmega as mav  # noqa: E402


def real_binary() -> tuple[str | None, str]:
    """(path, why not): $ARDUPILOT_SITL, else ../shared/sitl/arducopter from the project root."""
    env = os.environ.get("ARDUPILOT_SITL")
    path = Path(env) if env else REPO.parent / "shared" / "sitl" / "arducopter"
    if not path.is_file() or not os.access(path, os.X_OK):
        return None, f"no ArduPilot SITL binary ({'ARDUPILOT_SITL' if env else '../shared/sitl/arducopter'} = {path})"
    return str(path), ""


def tcp_pair() -> tuple[socket.socket, socket.socket]:
    """A connected TCP pair on 127.0.0.1 (ground station side, vehicle side)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    a = socket.create_connection(srv.getsockname())
    b, _ = srv.accept()
    srv.close()
    for s in (a, b):
        s.setblocking(False)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)   # no Nagle delay of the small messages
    return a, b


def read_all(sock: socket.socket) -> bytes:
    out = b""
    wait = 0.002          # loopback delivers during the sender's send(); the first wait is a margin only
    while select.select([sock], [], [], wait)[0]:
        wait = 0.0
        data = sock.recv(65536)
        if not data:
            break
        out += data
    return out


class FakeCopter:
    """A scripted ArduCopter on the other end of a socket, driven by the test's clock.

    It sends HEARTBEAT at 1 Hz (until ``silent_from``), the requested streams' content at every call, an EKF
    and GPS that become usable at ``ready_at`` s, refuses the first ``refusals`` arm commands with a STATUSTEXT
    reason (all of them if refusals < 0), and acts on mode, takeoff and land like the firmware (land: on the
    ground and disarmed ``land_time`` s later)."""

    def __init__(self, sock, *, ready_at=20.0, refusals=0, silent_from=None, land_time=3.0):
        self.sock = sock
        self.m = mav.MAVLink(None, srcSystem=1, srcComponent=1)
        self.rx = mav.MAVLink(None, srcSystem=1, srcComponent=1)
        self.ready_at, self.refusals, self.silent_from, self.land_time = ready_at, refusals, silent_from, land_time
        self.mode, self.armed, self.in_air = 0, False, False
        self.intervals: dict[int, float] = {}
        self.commands: list[tuple[float, int, tuple]] = []
        self.targets: list[tuple[float, object]] = []
        self.arm_attempts: list[float] = []
        self.params: dict[str, float] = {}
        self._next_hb = 0.0
        self._land_at = None
        self.got_gcs_packet = False

    def _send(self, msg):
        self.sock.sendall(msg.pack(self.m))

    def _ack(self, cmd, result):
        self._send(mav.MAVLink_command_ack_message(cmd, result, 0, 0, 255, 190))

    def step(self, now: float) -> None:
        for msg in self.rx.parse_buffer(read_all(self.sock)) or []:
            self.got_gcs_packet = True
            self._handle(msg, now)
        if self.silent_from is not None and now >= self.silent_from:
            return
        if now >= self._next_hb:
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            self._send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                                                     self.mode, mav.MAV_STATE_STANDBY, 3))
            self._next_hb = now + 1.0
        ok = now >= self.ready_at
        ms = int(now * 1000)
        if mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT in self.intervals:
            flags = (0x1 | 0x2 | 0x4 | 0x10 | 0x20) if ok else (0x1 | 0x80)
            self._send(mav.MAVLink_ekf_status_report_message(flags, 0, 0, 0, 0, 0))
        if mav.MAVLINK_MSG_ID_GPS_RAW_INT in self.intervals:
            self._send(mav.MAVLink_gps_raw_int_message(ms * 1000, 3 if now >= min(10.0, self.ready_at) else 1, 0, 0, 0, 0, 0, 0, 0, 10))
        if mav.MAVLINK_MSG_ID_HOME_POSITION in self.intervals and ok:
            self._send(mav.MAVLink_home_position_message(-72750000, -359650000, 540000, 0, 0, 0, [1, 0, 0, 0],
                                                         0, 0, 0))
        if mav.MAVLINK_MSG_ID_SYS_STATUS in self.intervals:
            pre = mav.MAV_SYS_STATUS_PREARM_CHECK
            self._send(mav.MAVLink_sys_status_message(pre, pre, pre if ok else 0, 0, 12000, 0, -1, 0, 0, 0, 0, 0, 0))
        if mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE in self.intervals:
            landed = mav.MAV_LANDED_STATE_IN_AIR if self.in_air else mav.MAV_LANDED_STATE_ON_GROUND
            self._send(mav.MAVLink_extended_sys_state_message(0, landed))
        if mav.MAVLINK_MSG_ID_SYSTEM_TIME in self.intervals:
            self._send(mav.MAVLink_system_time_message(0, ms))
        if self._land_at is not None and now >= self._land_at:
            self.in_air, self.armed, self._land_at = False, False, None

    def _handle(self, msg, now):
        t = msg.get_type()
        if t == "COMMAND_LONG":
            p = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
            self.commands.append((now, msg.command, p))
            if msg.command == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
                self.intervals[int(p[0])] = p[1]
                self._ack(msg.command, mav.MAV_RESULT_ACCEPTED)
            elif msg.command == mav.MAV_CMD_DO_SET_MODE:
                self.mode = int(p[1])
                self._ack(msg.command, mav.MAV_RESULT_ACCEPTED)
                if self.mode == 9 and self.in_air:
                    self._land_at = now + self.land_time
            elif msg.command == mav.MAV_CMD_COMPONENT_ARM_DISARM:
                self.arm_attempts.append(now)
                if self.refusals != 0:
                    self.refusals -= 1
                    self._send(mav.MAVLink_statustext_message(mav.MAV_SEVERITY_CRITICAL,
                                                              b"PreArm: Need Position Estimate"))
                    self._ack(msg.command, mav.MAV_RESULT_FAILED)
                else:
                    self.armed = True
                    self._ack(msg.command, mav.MAV_RESULT_ACCEPTED)
            elif msg.command == mav.MAV_CMD_NAV_TAKEOFF:
                ok = self.armed and self.mode == 4
                self.in_air = self.in_air or ok
                self._ack(msg.command, mav.MAV_RESULT_ACCEPTED if ok else mav.MAV_RESULT_FAILED)
        elif t == "SET_POSITION_TARGET_GLOBAL_INT":
            self.targets.append((now, msg))
        elif t == "PARAM_SET":
            self.params[msg.param_id] = msg.param_value


def lean_sitl(*, gcs_port: bool = False, **params: float) -> dict:
    """SitlOptions / SitlConfig keywords for the SITL tests whose assertions do not depend on the firmware's
    rates (issue 31): physics at 400 frames a second instead of 1200 and the main loop at 200 Hz instead of 400
    (the firmware refuses to arm when its gyro rate, the frame rate, is below 1.8 x SCHED_LOOP_RATE), and no
    ground-station ports unless the test forwards them.  A third of the frames, each with fewer system calls
    in the firmware: about half the CPU of a flight (bench/results/test_suite_2026-11-29_sitl.md).  The flight is
    a different one from the shipped FMU's default; ``params`` are further firmware parameters."""
    return {"frame_rate": 400, "gcs_port": gcs_port, "params": {"SCHED_LOOP_RATE": 200.0, **params}}
