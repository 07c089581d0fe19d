"""SITL's physics in lock-step: ``LockstepPhysics`` answers ArduPilot SITL's servo frames (``--model JSON``).

Usage (the SITL vehicle FMU's side)::

    phys = LockstepPhysics(instance=N)           # binds UDP 127.0.0.1:9002+10N before SITL starts
    ... start arducopter --model JSON:127.0.0.1 -I N ..., connect MAVLink to tcp:127.0.0.1:5760+10N ...
    state = phys.advance(h, wind_ned=(wn, we, wd))   # in doStep(t, h): exactly round(h*1200) frames
    state.position_ned, state.velocity_ned, state.euler, state.power_w, phys.time ...
    phys.close()

``advance`` answers exactly round(duration * frame_rate) new servo frames, each with the state one frame
(1/frame_rate s) later, and returns; SITL blocks between calls, so the firmware's clock equals ``time`` at
every return (to the microsecond below; docs/sitl_physics.md).  A frame SITL sends again with the same
frame_count (it re-sends after ~1 s without an answer) is counted in ``stale_frames`` and never answered:
SITL re-sends only while our answer has not reached it, and on loopback our answer is never lost, so a second
answer would be read as the answer to SITL's *next* frame and put the firmware one frame ahead of the physics
for the rest of the run (a wall-clock-dependent flight).  A frame_count going backwards is a restarted
SITL: the vehicle is put back on the ground at the origin, time restarts at 0, ``resets`` counts it.  No new
frame within ``wall_timeout`` wall seconds raises SitlSilent (the frames answered so far stay done).
SITL sends its first frame only after a MAVLink client has connected to its SERIAL0 (TCP 5760+10N).
A signal (Ctrl-C) interrupts the compiled loop at once: KeyboardInterrupt is raised from ``advance``.

The answering loop runs in C without the GIL when the compiled kernel is available (else the Python twin,
bit-identical, ~20x slower), so several vehicles can advance in parallel threads.
"""
from __future__ import annotations

import math
import socket
from dataclasses import dataclass

from . import physics as ph
from .iris import IrisParams

BASE_PORT = 9002          # SITL's JSON physics port for instance 0; +10 per instance (-I N)


class SitlSilent(RuntimeError):
    """SITL sent no new servo frame within the wall-clock timeout."""


class SitlSocketError(RuntimeError):
    """The UDP socket failed while answering frames."""


@dataclass(frozen=True)
class VehicleState:
    """The vehicle after the last answered frame.  NED about the home point, body FRD, SI units."""
    time: float                   # s physics time (frames answered since start or the last SITL restart / rate)
    frame_count: int              # SITL's frame_count of the last answered frame (-1: none yet)
    position_ned: tuple           # m
    velocity_ned: tuple           # m/s
    quaternion: tuple             # (w, x, y, z) body -> NED
    euler: tuple                  # (roll, pitch, yaw) rad, ZYX
    gyro: tuple                   # rad/s body rates (p, q, r) = the IMU gyro
    accel_body: tuple             # m/s^2 specific force in body axes = the IMU accelerometer
    rotor_speed: tuple            # rad/s motors 1..4
    thrust: tuple                 # N motors 1..4
    pwm: tuple                    # us servo outputs 1..4 of the last frame
    power_w: float                # W electrical power (motors + avionics) at the last frame
    energy_j: float               # J electrical energy since the start
    mean_power_w: float           # W mean electrical power over the last advance (energy / duration)
    on_ground: bool


def euler_from_quaternion(qw, qx, qy, qz):
    """(roll, pitch, yaw) rad, aerospace ZYX convention."""
    roll = math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy))
    sp = 2.0 * (qw * qy - qz * qx)
    pitch = math.asin(max(-1.0, min(1.0, sp)))
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return roll, pitch, yaw


class LockstepPhysics:
    """The 6-DoF Iris answering one SITL instance's JSON physics frames (see the module docstring).

    instance      SITL's -I N: the UDP port is 9002 + 10 N unless ``port`` is given.
    params        IrisParams (frame "x" needs FRAME_TYPE 1 in the firmware; "+" matches copter.parm's 0).
    frame_rate    frames per simulated second (SITL's SIM_RATE_HZ / --rate; copter: 1200).
    bind_host     the address to bind (loopback only by default).
    wall_timeout  s of wall clock to wait for a new frame before SitlSilent.
    yaw_deg       initial heading (deg, clockwise from north); the vehicle starts level on the ground.
    no_time_sync  send "no_time_sync":1, so SITL runs as fast as we answer instead of pacing to --speedup.
    kernel        physics.Kernel to use (default: physics.load(), the compiled twin when it can be had).
    watch         optional callable, asked every ``watch_interval`` s while SITL is silent; a string it returns
                  (e.g. "SITL exited with code -9") ends the advance at once with SitlSilent naming it.
    """

    def __init__(self, instance: int = 0, params: IrisParams = IrisParams(), frame_rate: int = 1200,
                 bind_host: str = "127.0.0.1", port: int | None = None, wall_timeout: float = 10.0,
                 yaw_deg: float = 0.0, no_time_sync: bool = True, kernel=None,
                 watch=None, watch_interval: float = 0.5):
        if wall_timeout <= 0:
            raise ValueError(f"wall_timeout must be > 0 s, not {wall_timeout}")
        self.params = params
        self.frame_rate = int(frame_rate)
        self.instance = int(instance)
        self.port = BASE_PORT + 10 * self.instance if port is None else int(port)
        self.wall_timeout = float(wall_timeout)
        self.watch, self.watch_interval = watch, float(watch_interval)
        self.kernel = ph.load() if kernel is None else kernel
        self._p = ph.kernel_params(params, self.frame_rate, math.radians(yaw_deg))
        self._s = ph.initial_state(self._p)
        self._io = [0.0] * ph.N_IO
        self._io[ph.IO_TIMEOUT] = self.wall_timeout
        self._io[ph.IO_NO_TIME_SYNC] = 1.0 if no_time_sync else 0.0
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.bind((bind_host, self.port))
        except OSError as exc:
            self._sock.close()
            raise OSError(exc.errno, f"cannot bind the SITL physics port {bind_host}:{self.port} "
                                     f"(instance {self.instance}): {exc.strerror}") from None
        self._serve = self.kernel.bind_serve(self._sock, self._p)
        self._mean_power = self._s[ph.S_POWER]
        self.timing = {"wait": 0.0, "physics": 0.0, "io": 0.0}   # wall s: firmware/scheduler, kernel, syscalls
        self.closed = False

    # ---------------------------------------------------------------- stepping
    def advance(self, duration: float, wind_ned=(0.0, 0.0, 0.0)) -> VehicleState:
        """Answer exactly round(duration * frame_rate) new frames with the wind (NED air velocity, m/s)
        held, and return the state; SitlSilent if SITL goes quiet for wall_timeout."""
        if self.closed:
            raise RuntimeError("LockstepPhysics.advance after close()")
        n = round(duration * self.frame_rate)
        if n < 0:
            raise ValueError(f"advance: negative duration {duration}")
        s, io = self._s, self._io
        s[ph.S_WN], s[ph.S_WE], s[ph.S_WD] = (float(w) for w in wind_ned)
        e0 = s[ph.S_ENERGY]
        done, status, silent, reason = 0, ph.OK, 0.0, ""
        while done < n:
            io[ph.IO_NFRAMES] = float(n - done)
            left = self.wall_timeout - silent
            io[ph.IO_TIMEOUT] = min(left, self.watch_interval) if self.watch else left
            got = self._serve(s, io)
            done += got
            self.timing["wait"] += io[ph.IO_T_WAIT]
            self.timing["physics"] += io[ph.IO_T_PHYS]
            self.timing["io"] += io[ph.IO_T_IO]
            status = int(io[ph.IO_STATUS])
            if status == ph.INTERRUPTED:   # back in Python a pending signal handler has run (Ctrl-C raises)
                continue
            if status != ph.SILENT:
                break
            silent = (0.0 if got else silent) + io[ph.IO_WAITED]
            io[ph.IO_WAITED] = silent
            reason = self.watch() if self.watch else ""
            if reason or silent >= self.wall_timeout - 1e-6:
                break
        if done:
            self._mean_power = (s[ph.S_ENERGY] - e0) * self.frame_rate / done
        if status == ph.SILENT:
            raise SitlSilent(f"SITL (UDP port {self.port}) sent no new servo frame for {io[ph.IO_WAITED]:.1f} s "
                             f"of wall clock{': ' + reason if reason else ''} (physics time {self.time:.4f} s, "
                             f"{done} of {n} frames of this step answered, {int(s[ph.S_STALE])} re-sent frames seen)")
        if status == ph.SOCKET_ERROR:
            raise SitlSocketError(f"SITL physics socket (UDP port {self.port}) failed: "
                                  f"{_strerror(int(io[ph.IO_ERRNO]))}")
        return self.state

    # ---------------------------------------------------------------- read-outs
    @property
    def time(self) -> float:
        """s physics time = frames answered since the start (or the last SITL restart) / frame_rate."""
        return self._s[ph.S_K] / self.frame_rate

    @property
    def frames_answered(self) -> int:
        """New frames answered in all (re-sent answers not counted)."""
        return int(self._s[ph.S_ANSWERED])

    @property
    def resets(self) -> int:
        return int(self._s[ph.S_RESETS])

    @property
    def stale_frames(self) -> int:
        """Re-sent frames received (same frame_count as the last answered; never answered)."""
        return int(self._s[ph.S_STALE])

    @property
    def sitl_frame_rate(self) -> int:
        """The frame_rate field of SITL's last packet (0 before the first)."""
        return int(self._s[ph.S_SITL_RATE])

    @property
    def state(self) -> VehicleState:
        s, p = self._s, self._p
        q = tuple(s[ph.S_QW:ph.S_QZ + 1])
        rotors = tuple(s[ph.S_M1:ph.S_M4 + 1])
        return VehicleState(
            time=self.time, frame_count=int(s[ph.S_LAST]) if s[ph.S_HAS_LAST] else -1,
            position_ned=tuple(s[ph.S_PN:ph.S_PD + 1]), velocity_ned=tuple(s[ph.S_VN:ph.S_VD + 1]),
            quaternion=q, euler=euler_from_quaternion(*q), gyro=tuple(s[ph.S_RP:ph.S_RR + 1]),
            accel_body=tuple(s[ph.S_FX:ph.S_FZ + 1]), rotor_speed=rotors,
            thrust=tuple(p[ph.P_KF] * w * w for w in rotors), pwm=tuple(s[ph.S_PWM1:ph.S_PWM4 + 1]),
            power_w=s[ph.S_POWER], energy_j=s[ph.S_ENERGY], mean_power_w=self._mean_power,
            on_ground=s[ph.S_GROUND] != 0.0)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _strerror(code: int) -> str:
    import os
    return f"{os.strerror(code)} (errno {code})" if code else "unknown error"
