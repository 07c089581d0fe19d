"""UavSitl FMU shell (pythonfmu): the UAV dynamics component flown by a real ArduCopter SITL.

Same inputs and outputs as UavDynamics (docs/uav_connectors.md) plus what SITL adds; the vehicle logic is
sitlsim/vehicle.py, the couplings and process management docs/sitl.md.  SITL is started and made ready (about
42 s of vehicle time) in exitInitializationMode, before the mission clock starts; its folder (eeprom, logs) is
``workdir`` or else ``$COSIM_MASTER_OUTPUT/sitl/<instance name>`` (the run's output folder, set by cosim-master).
"""
import os
import re
import sys
import tempfile

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds sitlsim/ and uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from sitlsim.vehicle import SitlConfig, SitlFault, SitlVehicle  # noqa: E402
from uavsim import params as P  # noqa: E402
from uavsim.fmi import UnitsMixin  # noqa: E402
from uavsim.geodesy import EnuFrame  # noqa: E402

_REAL_PARAMS = [  # name, unit, default, description
    ("origin_lat", "deg", -7.2153, "latitude of the ENU origin (base), WGS84"),
    ("origin_lon", "deg", -35.9098, "longitude of the ENU origin (base), WGS84"),
    ("origin_alt", "m", 550.0, "ellipsoidal altitude of the ENU origin"),
    ("home_x", "m", 0.0, "initial (home) east position = SITL's home"),
    ("home_y", "m", 0.0, "initial (home) north position = SITL's home"),
    ("home_yaw", "deg", 0.0, "initial heading, clockwise from north"),
    ("takeoff_altitude", "m", P.TAKEOFF_ALTITUDE, "takeoff altitude above the origin"),
    ("preflight_time", "s", 0.0, "mission time before which a takeoff command waits (staggered take-offs)"),
    ("speedup", "1", 50.0, "paced: the largest SIM_SPEEDUP; lockstep: SITL's --speedup (unused: no_time_sync)"),
    ("wall_timeout", "s", 30.0, "wall-clock seconds without progress before the step fails"),
    ("heartbeat_timeout", "s", 5.0, "vehicle seconds without HEARTBEAT before the step fails"),
    ("ready_timeout", "s", 120.0, "vehicle seconds allowed to get ready (EKF, GPS, pre-arm)"),
    ("arm_timeout", "s", 30.0, "vehicle seconds of refused arming before the step fails"),
]
_STR_PARAMS = [
    ("sitl_binary", "", "path of the arducopter SITL executable; empty: $ARDUPILOT_SITL"),
    ("defaults", "", "firmware defaults file; empty: copter.parm next to the binary"),
    ("frame", "x", "motor layout: x or + (FRAME_TYPE 1 / 0)"),
    ("coupling", "lockstep", "lockstep (--model JSON, our physics, deterministic) or paced (--model quad)"),
    ("params", "", "extra firmware parameters: NAME=VALUE, comma-separated"),
    ("workdir", "", "SITL's working folder; empty: $COSIM_MASTER_OUTPUT/sitl/<instance name>"),
]
_INT_PARAMS = [("instance", -1, "SITL instance -I N (ports 5760+10N, 9002+10N); -1: the first free one"),
               ("sysid", 1, "MAVLink system id of the vehicle"),
               ("frame_rate", 0, "physics frames per second (SITL --rate; the firmware needs its gyro rate at least "
                                 "1.8 x SCHED_LOOP_RATE); 0: the firmware's own, 1200")]
_BOOL_PARAMS = [("gcs_port", True, "SITL serves ground stations on SERIAL1 and SERIAL2 (TCP 5762/5763+10N; "
                                   "cosim-master --mavlink forwards SERIAL1); false: headless, only this FMU's link")]
_GEODETIC = ("lat", "lon", "alt")
_OUT_REAL = [
    ("x", "m", "east position"), ("y", "m", "north position"), ("z", "m", "height above origin (up)"),
    ("vx", "m/s", "east velocity"), ("vy", "m/s", "north velocity"), ("vz", "m/s", "up velocity"),
    ("lat", "deg", "WGS84 latitude"), ("lon", "deg", "WGS84 longitude"),
    ("alt", "m", "altitude above the WGS84 ellipsoid"),
    ("airspeed", "m/s", "horizontal air-relative speed |v_xy - wind_xy|"),
    ("groundspeed", "m/s", "horizontal ground speed"),
    ("tilt", "deg", "lean angle of the body (from roll and pitch; lockstep only)"),
    ("motor_power", "W", "electrical power of the motors and avionics from the physics (lockstep; 0 in paced)"),
    ("slip", "s", "vehicle clock minus t+h at the end of the step (paced: how far SITL ran past it; "
                  "lockstep: 0 unless h is no whole number of frames)"),
    ("max_slip", "s", "the largest |slip| so far"),
    ("ready_time", "s", "vehicle time spent getting ready before t = 0"),
]
_OUT_INT = [("phase", "0 preflight, 1 takeoff, 2 fly, 3 land, 4 landed"),
            ("ready", "1 once the vehicle is ready to arm (always 1 after initialisation)"),
            ("flight_mode", "ArduCopter custom mode (4 GUIDED, 9 LAND, ...); -1 before the first HEARTBEAT"),
            ("armed", "1 while the motors are armed"), ("ekf_ok", "1 while the EKF reports a usable position"),
            ("sitl_instance", "the SITL instance N flown (ports 5760+10N, 9002+10N); -1 before the start")]

#: an instance name that is a folder name as it stands
_PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def _parse_params(text: str) -> dict:
    out = {}
    for item in (s.strip() for s in text.replace(";", ",").split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        try:
            out[name.strip().upper()] = float(value)
        except ValueError:
            raise SitlFault(f"parameter 'params': expected NAME=VALUE, got {item!r}") from None
        if not sep or not name.strip():
            raise SitlFault(f"parameter 'params': expected NAME=VALUE, got {item!r}")
    return out


class UavSitl(UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "UAV dynamics flown by ArduPilot SITL (ArduCopter) over MAVLink, lock-stepped or paced"
    # no direct feedthrough: the outputs are the vehicle's state, read back in exitInitializationMode and doStep
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _REAL_PARAMS:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        for name, default, desc in _STR_PARAMS:
            setattr(self, name, default)
            self.par_str(name, desc)
        for name, default, desc in _INT_PARAMS:
            setattr(self, name, default)
            self.par_int(name, desc)
        for name, default, desc in _BOOL_PARAMS:
            setattr(self, name, default)
            self.par_bool(name, desc)
        self.cmd = 0
        self.in_int("cmd", "0 idle/hold, 1 takeoff, 2 goto setpoint, 3 land")
        for name, unit, desc in [("sp_x", "m", "setpoint east"), ("sp_y", "m", "setpoint north"),
                                 ("sp_z", "m", "setpoint up"), ("wind_x", "m/s", "wind (air velocity) east"),
                                 ("wind_y", "m/s", "wind (air velocity) north"),
                                 ("wind_z", "m/s", "wind (air velocity) up")]:
            setattr(self, name, 0.0)
            self.in_real(name, unit, desc)
        for name, unit, desc in _OUT_REAL:
            if name not in _GEODETIC:
                setattr(self, name, 0.0)
            self.out_real(name, unit, desc)
        for name, desc in _OUT_INT:
            setattr(self, name, 0)
            self.out_int(name, desc)
        self.flight_mode = self.sitl_instance = -1
        self._vehicle = None
        self._frame = None
        self._publish()

    def _workdir(self) -> str:
        if self.workdir:
            return self.workdir
        base = os.environ.get("COSIM_MASTER_OUTPUT") or tempfile.mkdtemp(prefix="cosim-sitl-")
        name = self.instance_name
        if _PLAIN_NAME.fullmatch(name):
            return os.path.join(base, "sitl", name)
        # an instance name is any string (Ecos 0.7.2 passes the path of the unpacked FMU): a folder
        # of its own, named after it
        folder = os.path.join(base, "sitl")
        os.makedirs(folder, exist_ok=True)
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.basename(name.rstrip("/\\"))) or "instance"
        return tempfile.mkdtemp(prefix=stem + "-", dir=folder)

    def _fail(self, exc, when: str):
        """Stop SITL, then raise the one-line reason (the master adds the component and the time)."""
        self.terminate()
        raise RuntimeError(f"SITL vehicle {self.instance_name} ({when}): {exc}") from None

    def exit_initialization_mode(self):
        self._frame = EnuFrame(self.origin_lat, self.origin_lon, self.origin_alt)
        lat, lon, _ = self._frame.to_geodetic(self.home_x, self.home_y, 0.0)
        try:
            cfg = SitlConfig(binary=self.sitl_binary, defaults=self.defaults, workdir=self._workdir(),
                             home=(lat, lon, self.origin_alt, self.home_yaw), coupling=self.coupling.strip(),
                             frame=self.frame.strip(), speedup=self.speedup, instance=int(self.instance),
                             sysid=int(self.sysid), takeoff_altitude=self.takeoff_altitude,
                             preflight_time=self.preflight_time,
                             params=_parse_params(self.params), wall_timeout=self.wall_timeout,
                             heartbeat_timeout=self.heartbeat_timeout, ready_timeout=self.ready_timeout,
                             arm_timeout=self.arm_timeout, name=self.instance_name,
                             frame_rate=int(self.frame_rate), gcs_port=bool(self.gcs_port))
            self._vehicle = SitlVehicle(cfg, (self.home_x, self.home_y))
            self._vehicle.start()
        except SitlFault as exc:
            self._fail(exc, "start")
        self._publish()

    def _publish(self):
        v = self._vehicle
        if v is None:
            self.x, self.y, self.z = self.home_x, self.home_y, 0.0
            self.vx = self.vy = self.vz = 0.0
            return
        self.x, self.y, self.z = v.pos
        self.vx, self.vy, self.vz = v.vel
        self.airspeed, self.groundspeed, self.tilt = v.airspeed, v.groundspeed, v.tilt
        self.motor_power, self.slip, self.max_slip = v.power, v.slip, v.max_slip
        self.ready_time = v.ready_time
        link = v.link
        self.phase, self.ready = int(v.phase), int(link.ready)
        self.flight_mode, self.armed, self.ekf_ok = link.custom_mode, int(link.armed), int(link.ekf_ok)
        self.sitl_instance = v.instance

    def _geodetic(self):
        fr = self._frame or EnuFrame(self.origin_lat, self.origin_lon, self.origin_alt)
        return fr.to_geodetic(self.x, self.y, self.z)

    lat = property(lambda self: self._geodetic()[0])
    lon = property(lambda self: self._geodetic()[1])
    alt = property(lambda self: self._geodetic()[2])

    def do_step(self, current_time, step_size):
        if self._vehicle is None:
            self._fail("not started (exitInitializationMode failed or was not called)", f"t={current_time:g}")
        try:
            self._vehicle.step(current_time, step_size, int(self.cmd), (self.sp_x, self.sp_y, self.sp_z),
                               (self.wind_x, self.wind_y, self.wind_z))
        except SitlFault as exc:
            self._fail(exc, f"vehicle time {self._vehicle.vtime:.3f} s")
        self._publish()
        return True

    def terminate(self):
        if self._vehicle is not None:
            self._vehicle.close()
            self._vehicle = None
