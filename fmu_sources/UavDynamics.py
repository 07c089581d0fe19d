"""UavDynamics FMU shell (pythonfmu): maps FMI variables to uavsim.dynamics.Dynamics.

Connectors: docs/uav_connectors.md; model and parameter sources: docs/uav_models.md.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from uavsim import params as P  # noqa: E402
from uavsim.dynamics import Dynamics, DynamicsParams  # noqa: E402
from uavsim.fmi import StateMixin, UnitsMixin  # noqa: E402
from uavsim.kernels import load as load_kernels  # noqa: E402
from uavsim.native import load_extension  # noqa: E402
from uavsim.geodesy import EnuFrame  # noqa: E402

_PARAMS = [  # name, unit, default, description
    ("origin_lat", "deg", -7.2153, "latitude of the ENU origin (base), WGS84"),
    ("origin_lon", "deg", -35.9098, "longitude of the ENU origin (base), WGS84"),
    ("origin_alt", "m", 550.0, "ellipsoidal altitude of the ENU origin"),
    ("home_x", "m", 0.0, "initial (home) east position"),
    ("home_y", "m", 0.0, "initial (home) north position"),
    ("takeoff_altitude", "m", P.TAKEOFF_ALTITUDE, "takeoff altitude above the origin"),
    ("mass", "kg", P.MASS, "take-off mass"),
    ("flat_plate_area", "m2", P.FLAT_PLATE_AREA, "equivalent flat-plate drag area Cd*A"),
    ("rho", "kg/m3", P.RHO_SL, "air density"),
    ("max_tilt_deg", "deg", P.MAX_TILT_DEG, "lean-angle limit (ANGLE_MAX)"),
    ("speed", "m/s", P.WP_SPEED, "horizontal waypoint speed (WPNAV_SPEED)"),
    ("accel", "m/s2", P.WP_ACCEL, "horizontal acceleration limit (WPNAV_ACCEL)"),
    ("speed_up", "m/s", P.SPEED_UP, "climb rate (WPNAV_SPEED_UP)"),
    ("speed_dn", "m/s", P.SPEED_DN, "descent rate (WPNAV_SPEED_DN)"),
    ("accel_z", "m/s2", P.ACCEL_Z, "vertical acceleration limit (WPNAV_ACCEL_Z)"),
    ("land_speed", "m/s", P.LAND_SPEED, "final landing descent rate (LAND_SPEED)"),
    ("land_alt_low", "m", P.LAND_ALT_LOW, "altitude below which land_speed applies (LAND_ALT_LOW)"),
    ("pos_p", "1/s", P.POS_XY_P, "horizontal position gain (PSC_POSXY_P)"),
    ("pos_z_p", "1/s", P.POS_Z_P, "vertical position gain (PSC_POSZ_P)"),
    ("vel_p", "1/s", P.VEL_XY_P, "velocity-loop P gain (PSC_VELXY_P)"),
    ("vel_i", "1/s2", P.VEL_XY_I, "velocity-loop I gain (PSC_VELXY_I)"),
    ("preflight_time", "s", P.PREFLIGHT_TIME, "duration of the preflight check"),
    ("substep", "s", P.SUBSTEP, "internal integration sub-step"),
]
_GEODETIC = ("lat", "lon", "alt")
_EXT = load_extension("_dynamics_ext", os.path.join(_HERE, "uavsim"))


def _geodetic_properties(ext):
    """The properties lat, lon, alt: getters in C when the extension is there (a recorder reads them at every
    sample: three Python frames each), else UavDynamics.geodetic's items; both compute and cache alike."""
    if ext is not None:
        return property(ext.lat), property(ext.lon), property(ext.alt)
    return (property(lambda self: self.geodetic()[0]), property(lambda self: self.geodetic()[1]),
            property(lambda self: self.geodetic()[2]))
_OUT_REAL = [
    ("x", "m", "east position"), ("y", "m", "north position"), ("z", "m", "height above origin (up)"),
    ("vx", "m/s", "east velocity"), ("vy", "m/s", "north velocity"), ("vz", "m/s", "up velocity"),
    ("lat", "deg", "WGS84 latitude"), ("lon", "deg", "WGS84 longitude"),
    ("alt", "m", "altitude above the WGS84 ellipsoid"),
    ("airspeed", "m/s", "horizontal air-relative speed |v_xy - wind_xy|"),
    ("groundspeed", "m/s", "horizontal ground speed"),
    ("tilt", "deg", "lean angle of the horizontal thrust demand"),
]


class UavDynamics(StateMixin, UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Quadcopter (3DR Iris+ class) point-mass dynamics with ArduPilot-like position control"
    # no direct feedthrough: the outputs are published from the state in exitInitializationMode and doStep
    # (lat, lon, alt computed from x, y, z)
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _PARAMS:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        self.cmd = 0
        self.in_int("cmd", "0 idle/hold, 1 takeoff, 2 goto setpoint, 3 land")
        for name, unit, desc in [("sp_x", "m", "setpoint east"), ("sp_y", "m", "setpoint north"),
                                 ("sp_z", "m", "setpoint up"), ("wind_x", "m/s", "wind (air velocity) east"),
                                 ("wind_y", "m/s", "wind (air velocity) north"),
                                 ("wind_z", "m/s", "wind (air velocity) up")]:
            setattr(self, name, 0.0)
            self.in_real(name, unit, desc)
        for name, unit, desc in _OUT_REAL:
            if name not in _GEODETIC:          # lat, lon, alt are computed when read (properties below)
                setattr(self, name, 0.0)
            self.out_real(name, unit, desc)
        self.phase = 0
        self.out_int("phase", "0 preflight, 1 takeoff, 2 fly, 3 land, 4 landed")
        self.ready = 0
        self.out_int("ready", "1 once the preflight check has passed")
        self.wind_push = False
        self.par_bool("wind_push", "the wind carries the vehicle, corrected by the position loop only (the paper's "
                                   "'force that pushes the UAV'); false: air velocity in the drag law")
        self._model = None
        self._ext = None          # _dynamics_ext.step, the whole step in C, or None: the Python code below
        self.enu_frame = None        # the EnuFrame of the origin, from initialisation on
        self.geodetic_key = self.geodetic_value = None     # the last position converted and its (lat, lon, alt)
        self._publish()

    @property
    def model(self):
        """The uavsim model this shell steps (None before initialisation), for tests and tools that read or set
        its state."""
        return self._model

    def _build(self):
        names = DynamicsParams.__dataclass_fields__
        kw = {n: getattr(self, n) for n, *_ in _PARAMS if n in names}
        kw["wind_push"] = bool(self.wind_push)
        self._model = Dynamics(DynamicsParams(**kw), kernels=load_kernels(os.path.join(_HERE, "uavsim")))
        ext = load_extension("_dynamics_ext", os.path.join(_HERE, "uavsim"))
        self._ext = None if ext is None else ext.step
        self.enu_frame = EnuFrame(self.origin_lat, self.origin_lon, self.origin_alt)

    def exit_initialization_mode(self):
        self._build()
        self._publish()

    def _publish(self):
        m = self._model
        if m is None:
            self.x, self.y, self.z = self.home_x, self.home_y, 0.0
            self.vx = self.vy = self.vz = 0.0
            self.airspeed = self.groundspeed = self.tilt = 0.0
            self.phase, self.ready = 0, 0
        else:
            (self.x, self.y, self.z, self.vx, self.vy, self.vz, self.airspeed, self.groundspeed, self.tilt,
             self.phase, self.ready) = m.outputs()

    # The geodetic position is an output few masters read every step (cosim-master reads recorded-only
    # outputs when it samples), and the exact ENU -> WGS84 conversion is the costliest part of publishing
    # the outputs, so it is computed when read, once per position.
    def geodetic(self):
        """(lat, lon, alt) of (x, y, z), computed once per position (the compiled getters of _dynamics_ext.c read
        and fill the same cache: enu_frame, geodetic_key, geodetic_value)."""
        key = (self.x, self.y, self.z)
        fr = self.enu_frame
        if fr is None:     # before initialisation the origin parameters may still change
            return EnuFrame(self.origin_lat, self.origin_lon, self.origin_alt).to_geodetic(*key)
        if key != self.geodetic_key:
            self.geodetic_value = fr.to_geodetic(*key)
            self.geodetic_key = key
        return self.geodetic_value

    lat, lon, alt = _geodetic_properties(_EXT)

    def do_step(self, current_time, step_size):
        ext = self._ext
        # the compiled step (uavsim/_dynamics_ext.c) does this whole step (same results, bit for bit) on the model and
        # the FMU's variables (this instance's variable values), or, when it returns False, nothing
        if ext is not None and ext(self._model, self.__dict__, step_size):
            return True
        if self._model is None:
            self._build()
        self._model.step(step_size, int(self.cmd), (self.sp_x, self.sp_y, self.sp_z),
                         (self.wind_x, self.wind_y, self.wind_z))
        self._publish()
        return True
