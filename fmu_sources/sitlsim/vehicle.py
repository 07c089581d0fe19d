"""The SITL vehicle component: one ArduCopter SITL process, its MAVLink ground station and its time coupling.

``SitlVehicle`` offers what the UAV dynamics FMU offers (``step(h, cmd, set-point, wind)`` and ENU outputs), so
the FMU shell ``UavSitl.py`` stays a thin mapping.  Two couplings (docs/sitl.md):

* ``lockstep``: SITL runs ``--model JSON`` and our ``LockstepPhysics`` answers its servo frames; a step of h
  answers exactly h x frame_rate frames, so the firmware clock equals the master's at every communication point.
  After the frames, we wait until SITL has sent the *next* servo frame (it is then blocked on our answer, so
  everything it wrote to MAVLink for the step is already in our socket) and read MAVLink: what the ground station
  sees at a step boundary does not depend on the wall clock, and two runs are bit-identical.
* ``paced``: SITL runs its own physics (``--model quad``) at ``SIM_SPEEDUP``; a step waits until the vehicle's
  clock (``time_boot_ms`` of its messages) passes t+h and reports how far past it the vehicle was (``slip``).

Get-ready (heartbeat, streams, EKF and GPS, pre-arm: about 42 s of vehicle time) is spent in :meth:`start`,
i.e. during the FMU's initialisation, before the mission clock starts at t = 0.
"""
from __future__ import annotations

import fcntl
import math
import select
import socket
import termios
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import ap_location
from .mavlink_link import STREAMS, GroundStation, LinkError
from .process import SitlError, SitlProcess, wait_for_port

__all__ = ["SitlConfig", "SitlVehicle", "SitlFault", "COUPLINGS"]

COUPLINGS = ("lockstep", "paced")
PREFLIGHT, TAKEOFF, FLY, LAND, LANDED = 0, 1, 2, 3, 4      # the dynamics phases (uavsim.dynamics)
CMD_IDLE, CMD_TAKEOFF, CMD_GOTO, CMD_LAND = 0, 1, 2, 3
READY_SLICE = 0.1          # s of vehicle time per lock-step slice while getting ready
#: lock-step: the ground station takes the firmware's messages stamped at least this long (ms) before the step's
#: end (the firmware clock lags the physics clock by ~0.1 s: its boot), so that late bytes change nothing
LOCKSTEP_CUT_MS = 200
#: lock-step: stream requests at these vehicle times (s), and the cut from CUT_FROM on (before, no stamped
#: message flows yet; nothing taken from the link before then decides anything)
CONFIGURE_AT = (1.0, 2.0, 3.0)
CUT_FROM = 4.0
#: ArduCopter SITL's physics frame rate without --rate (../shared/sitl/README.md)
FIRMWARE_FRAME_RATE = 1200
#: no ground-station ports: SERIAL1 and SERIAL2 (TCP 5762/5763+10N) are not opened.  The firmware polls every
#: open serial port in every loop, listening or not; a fleet nobody watches live needs only SERIAL0, our link
#: (measured: the same flight, ~1.3 of ~10.7 system calls a physics frame fewer; docs/sitl.md)
HEADLESS_ARGS = ("--serial1", "none", "--serial2", "none")
#: lock-step: how often (wall s) a wait for the firmware's next frame checks that SITL is still running
WATCH_INTERVAL = 0.5


class SitlFault(RuntimeError):
    """A one-line reason why the SITL vehicle cannot go on (missing binary, crash, silence, refusal)."""


@dataclass
class SitlConfig:
    binary: str = ""                       # "" -> $ARDUPILOT_SITL
    defaults: str = ""                     # "" -> copter.parm next to the binary (if there)
    workdir: str = "sitl"
    home: tuple = (0.0, 0.0, 0.0, 0.0)     # lat, lon, alt (m), yaw (deg) of the pad
    coupling: str = "lockstep"
    frame: str = "x"                       # "x" or "+"
    speedup: float = 50.0                  # paced: the largest SIM_SPEEDUP used; lockstep: SITL's --speedup
    instance: int = -1                     # -1: the first free one
    sysid: int = 1
    takeoff_altitude: float = 20.0
    preflight_time: float = 0.0            # mission s before which a takeoff command waits (staggered take-offs)
    params: dict = field(default_factory=dict)   # extra firmware parameters NAME -> value
    frame_rate: int = 0                    # physics frames per s (SITL's --rate); 0: the firmware's own (1200)
    gcs_port: bool = True                  # SERIAL1/SERIAL2 listen for ground stations; False: headless
    wall_timeout: float = 30.0             # s of wall clock without progress -> fault
    heartbeat_timeout: float = 5.0         # s of vehicle time without HEARTBEAT -> fault
    ready_timeout: float = 120.0           # s of vehicle time to get ready
    arm_timeout: float = 30.0              # s of vehicle time of refused arming
    name: str = "uav"

    def defaults_path(self, binary: str) -> str:
        if self.defaults:
            return self.defaults
        near = Path(binary).with_name("copter.parm")
        return str(near) if near.is_file() else ""


class SitlVehicle:
    def __init__(self, cfg: SitlConfig, home_enu=(0.0, 0.0)):
        if cfg.coupling not in COUPLINGS:
            raise SitlFault(f"coupling must be one of {', '.join(COUPLINGS)}, not {cfg.coupling!r}")
        if cfg.frame_rate < 0:
            raise SitlFault(f"frame_rate must be 0 (the firmware's own) or positive, not {cfg.frame_rate}")
        self.cfg = cfg
        self.home_enu = tuple(float(v) for v in home_enu)
        # SITL's home as the firmware holds it (int 1e-7 deg): the origin of the physics' metres and of the GPS
        self.home_e7 = (ap_location.to_e7(cfg.home[0]), ap_location.to_e7(cfg.home[1]))
        self.proc: SitlProcess | None = None
        self.physics = None
        self.sock: socket.socket | None = None
        self.link: GroundStation | None = None
        self.t0 = 0.0              # vehicle time at mission t = 0
        self.ready_time = 0.0      # vehicle time spent getting ready
        self.instance = -1
        self.vtime = 0.0           # vehicle time now (s)
        self.pos = [self.home_enu[0], self.home_enu[1], 0.0]
        self.vel = [0.0, 0.0, 0.0]
        self.tilt = 0.0
        self.power = 0.0
        self.slip = 0.0
        self.max_slip = 0.0
        self.phase = PREFLIGHT
        self.wind = (0.0, 0.0, 0.0)
        self._flown = False
        self._going = False
        self._speedup = cfg.speedup
        self._wall_mark = None
        self._sim_wind = None
        self.timing = {"lockstep": 0.0, "link": 0.0, "step": 0.0}   # wall s (bench/bench_sitl.py)

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Start SITL, connect, and spend the get-ready time (before the mission clock starts)."""
        c = self.cfg
        try:
            lockstep = c.coupling == "lockstep"
            self.proc = SitlProcess(c.binary, c.workdir, model="JSON:127.0.0.1" if lockstep else "quad",
                                    home=c.home, defaults=None, speedup=c.speedup, sysid=c.sysid,
                                    instance=None if c.instance < 0 else c.instance, rate=c.frame_rate or None,
                                    extra_args=() if c.gcs_port else HEADLESS_ARGS)
            self.proc.defaults = self._defaults_files()
            n = self.instance = self.proc.claim()
            if lockstep:
                from .iris import IrisParams
                from .lockstep import LockstepPhysics
                self.physics = LockstepPhysics(instance=n, params=IrisParams(frame=c.frame),
                                               frame_rate=c.frame_rate or FIRMWARE_FRAME_RATE,
                                               wall_timeout=c.wall_timeout, yaw_deg=float(c.home[3]),
                                               watch=self._exited, watch_interval=WATCH_INTERVAL)
            self.proc.start()
            self.sock = wait_for_port(self.proc.ports["mavlink"], c.wall_timeout, self.proc)
            self.sock.setblocking(False)
            streams = dict(STREAMS)
            streams[2] = 50.0       # SYSTEM_TIME: the vehicle clock (paced) and the lock-step cut, finely
            self.link = GroundStation(target_system=c.sysid, streams=streams,
                                      heartbeat_timeout=c.heartbeat_timeout, arm_timeout=c.arm_timeout,
                                      configure_at=CONFIGURE_AT if lockstep else ())
            self._get_ready()
        except (SitlError, LinkError) as exc:
            raise SitlFault(str(exc)) from None
        except Exception as exc:     # physics socket errors, SitlSilent, ...
            raise SitlFault(self._why(exc)) from None

    def _defaults_files(self) -> str:
        """copter.parm (or the given file) plus our own ``cosim.parm`` in the working folder: frame and extras."""
        c = self.cfg
        from .process import find_binary
        binary = find_binary(c.binary)
        base = c.defaults_path(binary)
        if base and not Path(base).is_file():
            raise SitlError(f"SITL defaults file not found: {base}")
        Path(c.workdir).mkdir(parents=True, exist_ok=True)
        own = Path(c.workdir) / "cosim.parm"
        # LOG_DISARMED 1: the DataFlash log is open from boot.  With 0 the firmware opens it when arming, in
        # its logging thread, and the arm then takes effect a main loop earlier or later depending on the wall
        # clock (measured: 42.2067 vs 42.2092 s), which would make lock-step runs differ
        lines = ["# written by the SITL vehicle FMU (sitlsim/vehicle.py)", "FRAME_CLASS 1",
                 f"FRAME_TYPE {1 if c.frame.lower() == 'x' else 0}", "LOG_DISARMED 1"]
        lines += [f"{k} {v:g}" for k, v in c.params.items()]
        own.write_text("\n".join(lines) + "\n")
        return ",".join(p for p in (base, str(own.resolve())) if p)

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None
        if self.physics is not None:
            self.physics.close()
            self.physics = None
        if self.proc is not None:
            self.proc.stop()
            self.proc = None

    # ------------------------------------------------------------------ faults
    def _exited(self) -> str:
        """Why SITL is gone ("" while it runs): asked while lock-step waits for a frame, so that a crashed or
        killed firmware ends the step at once instead of after wall_timeout of silence."""
        p = self.proc
        return (p.exit_reason() or "") if p is not None and p.proc is not None else ""

    def _why(self, exc) -> str:
        """The reason to report: SITL's own death explains a silent socket better than the socket does."""
        died = self.proc.exit_reason() if self.proc is not None and self.proc.proc is not None else None
        return died or str(exc) or type(exc).__name__

    # ------------------------------------------------------------------ MAVLink I/O
    def _exchange(self) -> None:
        out = self.link.update(self.vtime)
        if out:
            try:
                self.sock.sendall(out)
            except OSError as exc:
                raise SitlError(f"MAVLink connection lost: {exc.strerror or exc}") from None
            if self.physics is not None:
                self._until_delivered()
        self._drain()

    def _until_delivered(self) -> None:
        """Lock-step: wait until SITL's kernel has acknowledged our MAVLink bytes before we answer its next
        frame.  Nothing orders a TCP stream against a UDP datagram (on a loaded machine loopback delivery is
        deferred), and a command read one firmware loop later is a different flight."""
        deadline = time.perf_counter() + self.cfg.wall_timeout
        buf = bytearray(4)
        while True:
            fcntl.ioctl(self.sock.fileno(), termios.TIOCOUTQ, buf)
            if int.from_bytes(buf, "little") == 0:
                return
            if time.perf_counter() > deadline:
                raise SitlError(f"SITL did not take our MAVLink bytes for {self.cfg.wall_timeout:g} s of wall clock")
            time.sleep(0.0001)

    def _drain(self, wait: float = 0.0) -> bool:
        """Read what MAVLink has for us; True if anything came."""
        cut = (None if self.physics is None or self.vtime < CUT_FROM
               else int(round(self.vtime * 1000.0)) - LOCKSTEP_CUT_MS)
        got = False
        while select.select([self.sock], [], [], wait)[0]:
            try:
                data = self.sock.recv(65536)
            except BlockingIOError:
                break
            except OSError as exc:
                raise SitlError(f"MAVLink connection lost: {exc.strerror or exc}") from None
            if not data:
                raise SitlError(self.proc.exit_reason() or "SITL closed the MAVLink connection")
            self.link.feed(data, cut)
            got, wait = True, 0.0
        if not got and cut is not None:
            self.link.feed(b"", cut)       # held-back messages the new cut admits
        return got

    # ------------------------------------------------------------------ time
    def _advance_lockstep(self, h: float) -> None:
        w = self.wind
        t1 = time.perf_counter()
        st = self.physics.advance(h, (w[1], w[0], -w[2]))
        t2 = time.perf_counter()
        # SITL has the last answer; once it sends the next frame it has finished the step's loop (and its
        # MAVLink output is in our socket)
        sock = self.physics._sock
        waited = 0.0
        while not select.select([sock], [], [], WATCH_INTERVAL)[0]:
            waited += WATCH_INTERVAL
            if self._exited() or waited >= self.cfg.wall_timeout:
                raise SitlError(self._exited() or
                                f"SITL sent no servo frame for {self.cfg.wall_timeout:g} s of wall clock")
        self.vtime = self.physics.time
        t3 = time.perf_counter()
        self._drain()
        self.timing["lockstep"] += t2 - t1
        self.timing["link"] += time.perf_counter() - t3
        self._state_from_physics(st)

    def _state_from_physics(self, st) -> None:
        pn, pe, pd = st.position_ned
        vn, ve, vd = st.velocity_ned
        self.pos = [self.home_enu[0] + pe, self.home_enu[1] + pn, -pd]
        self.vel = [ve, vn, -vd]
        roll, pitch, _ = st.euler
        self.tilt = math.degrees(math.acos(max(-1.0, min(1.0, math.cos(roll) * math.cos(pitch)))))
        self.power = st.mean_power_w

    def _advance_paced(self, h: float, target: float) -> None:
        c = self.cfg
        if self._wall_mark is not None:
            self._pace(h, time.perf_counter() - self._wall_mark)
        deadline = time.perf_counter() + c.wall_timeout
        while self.vtime < target:
            self._drain(wait=min(0.05, max(0.0, deadline - time.perf_counter())))
            if self.link.boot_ms is not None:
                self.vtime = self.link.boot_ms / 1000.0
            if self.proc.exit_reason():
                raise SitlError(self.proc.exit_reason())
            if time.perf_counter() > deadline:
                raise SitlError(f"the vehicle clock stood at {self.vtime:.3f} s for {c.wall_timeout:g} s of wall "
                                f"clock (waiting for {target:.3f} s)")
            out = self.link.update(self.vtime)
            if out:
                self.sock.sendall(out)
        self._record_slip(target)
        self._wall_mark = time.perf_counter()
        loc = self.link.local
        if loc is not None:
            x, y, z, vx, vy, vz = loc
            self.pos = [self.home_enu[0] + y, self.home_enu[1] + x, -z]
            self.vel = [vy, vx, -vz]

    def _record_slip(self, target: float) -> None:
        """How far the vehicle clock is from the master's t+h after a step: paced, how far SITL ran past it;
        lock-step, what whole frames cannot hit (0 when h is a multiple of 1/frame_rate).  Rounded to the ns:
        the two clocks are sums of different floating-point terms."""
        self.slip = round(self.vtime - target, 9) + 0.0
        self.max_slip = max(self.max_slip, abs(self.slip))

    def _pace(self, h: float, master_wall: float) -> None:
        """Speed SITL up to the pace the master consumes steps at (at most cfg.speedup): a slower SITL makes
        the master wait, a faster one runs past the communication points (slip)."""
        want = max(1.0, min(self.cfg.speedup, h / max(master_wall, 1e-4)))
        if abs(want - self._speedup) > 0.25 * self._speedup:
            self._speedup = want
            self.link.set_param("SIM_SPEEDUP", round(want, 1))

    def _get_ready(self) -> None:
        c = self.cfg
        start = self.vtime
        while not self.link.ready:
            if self.physics is not None:
                self._exchange()
                self._advance_lockstep(READY_SLICE)
            else:
                self._exchange()
                self._drain(wait=0.05)
                if self.link.boot_ms is not None:
                    self.vtime = self.link.boot_ms / 1000.0
                if self.proc.exit_reason():
                    raise SitlError(self.proc.exit_reason())
            if self.vtime - start > c.ready_timeout:
                raise SitlError(f"not ready after {c.ready_timeout:g} s of vehicle time (stage {self.link.stage}; "
                                f"last message: {self.link.last_reason() or 'none'})")
        self.t0 = self.vtime
        self.ready_time = self.vtime - start
        if self.physics is None:
            # until the first step the master is busy with the other components: run slowly meanwhile, so
            # that the vehicle is not far past t = 0 when the mission starts; _pace speeds it up again
            self._speedup = 1.0
            self.link.set_param("SIM_SPEEDUP", 1.0)
            self.sock.sendall(self.link.update(self.vtime))

    # ------------------------------------------------------------------ the step
    def step(self, t: float, h: float, cmd: int, sp, wind) -> None:
        """Advance from mission time t to t+h with the strategy's command and set-point and the wind (ENU)."""
        w0 = time.perf_counter()
        try:
            self.wind = tuple(float(v) for v in wind)
            self._command(int(cmd), sp, t)
            if self.physics is not None:
                self._exchange()
                self._advance_lockstep(h)
                self._record_slip(self.t0 + t + h)
            else:
                self._wind_paced()
                self._exchange()
                self._advance_paced(h, self.t0 + t + h)
            self._update_phase()
        except (SitlError, LinkError) as exc:
            raise SitlFault(str(exc)) from None
        except SitlFault:
            raise
        except Exception as exc:
            raise SitlFault(self._why(exc)) from None
        finally:
            self.timing["step"] += time.perf_counter() - w0

    def _command(self, cmd: int, sp, t: float = 0.0) -> None:
        link = self.link
        if cmd in (CMD_TAKEOFF, CMD_GOTO) and link.stage == "ready" and t >= self.cfg.preflight_time - 1e-9:
            link.takeoff(self.cfg.takeoff_altitude)
        elif cmd == CMD_TAKEOFF and link.stage == "landed":
            link.takeoff(self.cfg.takeoff_altitude)
        elif cmd == CMD_LAND:
            link.land()
        if cmd == CMD_GOTO and self.phase == FLY:
            link.goto(*self._geodetic(float(sp[0]), float(sp[1])), float(sp[2]))
            self._going = True
        elif self._going and cmd != CMD_GOTO:       # goto released: hold where we are (as uavsim.dynamics)
            self._going = False
            link.goto(*self._geodetic(self.pos[0], self.pos[1]), self.pos[2])

    def _geodetic(self, x: float, y: float):
        """Our ENU point as the firmware's latitude/longitude: its own spherical rule about SITL's home (not
        WGS84, which would put a target 450 m north of home 2.9 m beyond it for the firmware; sitlsim/ap_location.py)."""
        lat, lon = ap_location.offset(*self.home_e7, y - self.home_enu[1], x - self.home_enu[0])
        return lat * 1.0e-7, lon * 1.0e-7

    def _update_phase(self) -> None:
        stage = self.link.stage
        if stage in ("guided", "arming", "takeoff") or (stage == "flying" and self.phase in (PREFLIGHT, LANDED)):
            self.phase = TAKEOFF if stage in ("takeoff", "flying") else self.phase
        if stage == "flying" and self.phase == TAKEOFF and self.pos[2] >= self.cfg.takeoff_altitude - 0.5:
            self.phase = FLY
            self._flown = True
        elif stage == "landing":
            self.phase = LAND
        elif stage == "landed":
            self.phase = LANDED

    def _wind_paced(self) -> None:
        """SITL's own physics takes the wind as parameters: speed and the direction it comes from."""
        wx, wy, _ = self.wind
        spd = round(math.hypot(wx, wy), 2)
        frm = round(math.degrees(math.atan2(-wx, -wy)) % 360.0, 1) if spd > 0 else 0.0
        if self._sim_wind != (spd, frm):
            self._sim_wind = (spd, frm)
            self.link.set_param("SIM_WIND_SPD", spd)
            self.link.set_param("SIM_WIND_DIR", frm)

    # ------------------------------------------------------------------ outputs
    @property
    def airspeed(self) -> float:
        return math.hypot(self.vel[0] - self.wind[0], self.vel[1] - self.wind[1])

    @property
    def groundspeed(self) -> float:
        return math.hypot(self.vel[0], self.vel[1])
