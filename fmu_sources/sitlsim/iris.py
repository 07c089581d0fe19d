"""Parameters of the 6-DoF Iris quadcopter answering ArduPilot SITL (docs/sitl_physics.md lists each source).

Sources (keys used below):

* [UAVM]   docs/uav_models.md / uavsim/params.py: the project's Iris figures (mass, rotors, drag area, power).
* [PX4]    PX4-SITL_gazebo-classic, models/iris/iris.sdf.jinja (the Iris model of PX4's Gazebo SITL):
           inertia, rotor positions and turning directions, motorConstant 5.84e-6 N/(rad/s)^2,
           momentConstant 0.06 m, maxRotVelocity 1100 rad/s, timeConstantUp 0.0125 s, timeConstantDown 0.025 s.
* [PX4OLD] the earlier revision of the same file (models/iris/iris.sdf): rotorDragCoefficient 8.06428e-5 N s/m.
* [APMOT]  ArduPilot Copter motor parameters (AP_MotorsMulticopter): MOT_THST_EXPO 0.65, MOT_SPIN_MIN 0.15,
           MOT_SPIN_MAX 0.95, MOT_PWM_MIN/MAX 1000/2000 us (copter.parm: MOT_THST_EXPO 0.65, RC3 1000-2000).
* [APFRAME] ArduPilot AP_MotorsMatrix motor numbering: QUAD X 1 front-right CCW, 2 back-left CCW,
           3 front-left CW, 4 back-right CW; QUAD PLUS 1 right CCW, 2 left CCW, 3 front CW, 4 back CW.
* [MOM]    momentum theory of the hovering rotor (Leishman, Principles of Helicopter Aerodynamics, 2nd ed.,
           2006, ch. 2): induced velocity v_i = sqrt(T / (2 rho A)), ideal power T v_i.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

G0 = 9.80665                 # m/s^2 standard gravity (ISO 80000-3), as uavsim.params

# body FRD positions (x forward, y right; m) and yaw sign (+1: CCW propeller, whose drag torque yaws the
# body clockwise seen from above = positive yaw) of motors 1..4 in ArduPilot's numbering [APFRAME][PX4]
FRAME_X = (((0.13, 0.22), +1), ((-0.13, -0.20), +1), ((0.13, -0.22), -1), ((-0.13, 0.20), -1))
_ARM = math.sqrt(0.13 * 0.13 + 0.21 * 0.21)      # the X frame's mean arm length, on the axes for PLUS
FRAME_PLUS = (((0.0, _ARM), +1), ((0.0, -_ARM), +1), ((_ARM, 0.0), -1), ((-_ARM, 0.0), -1))
FRAMES = {"x": FRAME_X, "+": FRAME_PLUS, "plus": FRAME_PLUS}


@dataclass(frozen=True)
class IrisParams:
    """Iris figures; ``kernel()`` turns them into the flat tuple the physics kernel reads."""
    mass: float = 1.5                    # kg [UAVM]
    inertia: tuple = (0.029125, 0.029125, 0.055225)   # kg m^2 about body x, y, z [PX4]
    frame: str = "x"                     # "x" (FRAME_TYPE 1) or "+" (FRAME_TYPE 0, copter.parm's default)
    motor_constant: float = 5.84e-6      # N/(rad/s)^2: thrust = k_f omega^2 [PX4]
    max_rot_velocity: float = 1100.0     # rad/s at full throttle [PX4]; max thrust 7.07 N per motor
    moment_constant: float = 0.06        # m: yaw drag torque = k_m thrust [PX4]
    time_constant_up: float = 0.0125     # s first-order rotor-speed lag, spinning up [PX4]
    time_constant_down: float = 0.025    # s spinning down [PX4]
    rotor_drag: float = 8.06428e-5       # N s/m per rad/s: in-plane drag = -c omega v_air,xy per rotor [PX4OLD]
    flat_plate_area: float = 0.05        # m^2 body drag S_FP = Cd A, quadratic in the air speed [UAVM]
    rho: float = 1.225                   # kg/m^3 ISA sea level [UAVM]
    thrust_expo: float = 0.65            # MOT_THST_EXPO: thrust fraction = (1-e) x + e x^2 [APMOT]
    spin_min: float = 0.15               # MOT_SPIN_MIN: actuator level of zero thrust [APMOT]
    spin_max: float = 0.95               # MOT_SPIN_MAX: actuator level of full thrust [APMOT]
    pwm_min: float = 1000.0              # us MOT_PWM_MIN [APMOT]
    pwm_max: float = 2000.0              # us MOT_PWM_MAX [APMOT]
    rotor_radius: float = 0.127          # m, 10 in propellers [UAVM]
    induced_correction: float = 0.1      # k of the induced power (1+k) T v_i [UAVM]
    profile_power: float = 24.08         # W whole vehicle at hover rotor speed (Zeng's P0) [UAVM]
    efficiency: float = 0.60             # shaft-to-electrical (motor x ESC) [UAVM]
    avionics_power: float = 5.0          # W [UAVM]
    gravity: float = G0

    @property
    def motors(self):
        try:
            return FRAMES[self.frame.lower()]
        except KeyError:
            raise ValueError(f"IrisParams.frame: {self.frame!r} is not one of {sorted(FRAMES)}") from None

    @property
    def max_thrust(self) -> float:
        """N per motor at full throttle."""
        return self.motor_constant * self.max_rot_velocity * self.max_rot_velocity

    @property
    def hover_omega(self) -> float:
        """rad/s of each rotor in hover (weight shared equally)."""
        return math.sqrt(self.mass * self.gravity / (4.0 * self.motor_constant))

    def pwm_for_thrust(self, thrust: float) -> float:
        """The steady PWM (us) at which one motor gives ``thrust`` N (inverse of the thrust curve)."""
        f = thrust / self.max_thrust
        e = self.thrust_expo
        x = f if e == 0.0 else ((e - 1.0) + math.sqrt((1.0 - e) ** 2 + 4.0 * e * f)) / (2.0 * e)
        a = self.spin_min + (self.spin_max - self.spin_min) * x
        return self.pwm_min + (self.pwm_max - self.pwm_min) * a

    @property
    def hover_pwm(self) -> float:
        """us: the PWM at which the four motors together carry the weight."""
        return self.pwm_for_thrust(self.mass * self.gravity / 4.0)


#: SITL's own IMU noise on top of our exact gyro/accelerometer values: off, so the firmware sees the physics
#: as it is (and one candidate source of run-to-run differences is gone; docs/sitl_physics.md, Determinism)
QUIET_SENSORS = {f"SIM_{s}{i}_RND": 0 for s in ("ACC", "GYR") for i in (1, 2, 3)}


def firmware_params(params: IrisParams = IrisParams(), quiet_sensors: bool = True) -> dict:
    """ArduCopter parameters that make the firmware's mixer and thrust model match this physics (frame, thrust
    curve, PWM range, hover thrust) and, if ``quiet_sensors``, switch SITL's own IMU noise off.  Write them
    into a second ``--defaults`` file after copter.parm."""
    frame = params.frame.lower()
    out = {"FRAME_CLASS": 1, "FRAME_TYPE": 1 if frame == "x" else 0,
           "MOT_THST_EXPO": params.thrust_expo, "MOT_SPIN_MIN": params.spin_min, "MOT_SPIN_MAX": params.spin_max,
           "MOT_PWM_MIN": int(params.pwm_min), "MOT_PWM_MAX": int(params.pwm_max),
           "MOT_THST_HOVER": round(params.mass * params.gravity / (4.0 * params.max_thrust), 4)}
    params.motors        # validates the frame name
    if quiet_sensors:
        out.update(QUIET_SENSORS)
    return out


def defaults_text(params: IrisParams = IrisParams(), quiet_sensors: bool = True) -> str:
    """firmware_params as the text of a SITL defaults file (one "NAME VALUE" per line)."""
    return "".join(f"{k} {v}\n" for k, v in firmware_params(params, quiet_sensors).items())
