"""Translational point-mass quadcopter with an ArduPilot-like position/velocity controller.

State: ENU position p (m), ENU velocity v (m/s), reference ("target") velocity v_t, velocity-loop
integrator.  Per fixed sub-step h (default 0.01 s), horizontally:

    e        = goal_xy - p_xy,  d = |e|
    |v_des|  = min(V_max, sqrt_controller(d, K_pos, A_max))          (ArduPilot AC_PosControl)
    v_t     <- v_t + clip(v_des - v_t, |.| <= A_max h)                (acceleration-limited reference)
    a_cmd    = a_ff + K_vp (v_t - v) + K_vi * I + D_still(v)          (PI velocity loop + feed-forward)
    |a_cmd| <= g tan(theta_max)                                       (thrust-limited lean angle)
    a        = a_cmd - (rho S_FP / 2m) |v - w| (v - w)               (quadratic drag on airspeed)
    v       <- v + a h ;  p <- p + v h                                (semi-implicit Euler)

where sqrt_controller(d) = K d for d <= A/K^2 and sqrt(2 A (d - A/(2K^2))) beyond (the braking
profile that stops at the goal without overshoot), a_ff = (v_t,new - v_t,old)/h and
D_still(v) = (rho S_FP/2m)|v| v is the still-air drag feed-forward (the autopilot knows its own
drag curve, not the wind: wind is rejected by the integrator, so a wind step produces a transient
drift).  With ``wind_push`` (the paper's reading of wind, "a force that pushes the UAV") the wind does not
enter the drag law: the vehicle is carried by the air mass, p <- p + (v + w) h, with v its velocity
relative to the air (the one the controller limits to V_max), and only the position loop corrects the
displacement (docs/uav_models.md, "The paper's rules").  Vertically the thrust authority is ample, so v_z follows an acceleration-limited
(ACCEL_Z) reference bounded by SPEED_UP / SPEED_DN (or LAND_SPEED below LAND_ALT_LOW when landing).

Phases (output ``phase``): 0 preflight (on ground; the check takes ``preflight_time`` from power-on),
1 takeoff (vertical climb to ``takeoff_altitude``), 2 fly, 3 land, 4 landed.
Commands (input ``cmd``): 0 idle / hold, 1 takeoff, 2 go to setpoint, 3 land.

This module is the reference: the plain code a reader follows and changes (:meth:`Dynamics._substep` is one
sub-step, :meth:`Dynamics.step` the FMU's step).  Its accelerators compute exactly the same, faster: the flying
sub-steps run in the loop of :mod:`uavsim.kernels` (``fly_py``, compiled as kernels.c) and the UavDynamics FMU's
whole step in uavsim/_dynamics_ext.c, which reads and sets the public fields of :class:`Dynamics`; both are declared
in uavsim/accelerators.py and checked against this code by the accelerator harness (``COSIM_MASTER_PURE_PYTHON=1``
switches them off).
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

from . import kernels as _kernels
from . import params as P

PREFLIGHT, TAKEOFF, FLY, LAND, LANDED = 0, 1, 2, 3, 4
CMD_IDLE, CMD_TAKEOFF, CMD_GOTO, CMD_LAND = 0, 1, 2, 3


def sqrt_controller(error: float, p: float, accel: float) -> float:
    """ArduPilot's sqrt_controller: speed demanded at distance ``error`` (>= 0) from the goal.

    Linear (gain p) within accel/p^2 of the goal, else the constant-deceleration braking curve
    sqrt(2 accel (error - accel/(2 p^2))), continuous in value and slope at the junction.
    """
    if error <= 0.0:
        return 0.0
    linear_dist = accel / (p * p)
    if error <= linear_dist:
        return p * error
    return math.sqrt(2.0 * accel * (error - 0.5 * linear_dist))


@dataclass
class DynamicsParams:
    mass: float = P.MASS                      # kg
    flat_plate_area: float = P.FLAT_PLATE_AREA  # m^2
    rho: float = P.RHO_SL                     # kg/m^3
    max_tilt_deg: float = P.MAX_TILT_DEG      # deg
    speed: float = P.WP_SPEED                 # m/s
    accel: float = P.WP_ACCEL                 # m/s^2
    speed_up: float = P.SPEED_UP              # m/s
    speed_dn: float = P.SPEED_DN              # m/s
    accel_z: float = P.ACCEL_Z                # m/s^2
    land_speed: float = P.LAND_SPEED          # m/s
    land_alt_low: float = P.LAND_ALT_LOW      # m
    pos_p: float = P.POS_XY_P                 # 1/s
    pos_z_p: float = P.POS_Z_P                # 1/s
    vel_p: float = P.VEL_XY_P                 # 1/s
    vel_i: float = P.VEL_XY_I                 # 1/s^2
    preflight_time: float = P.PREFLIGHT_TIME  # s
    takeoff_altitude: float = P.TAKEOFF_ALTITUDE  # m
    home_x: float = 0.0                       # m
    home_y: float = 0.0                       # m
    substep: float = P.SUBSTEP                # s
    g: float = P.G0                           # m/s^2
    wind_push: bool = False                   # wind carries the vehicle (paper) instead of dragging it

    @property
    def drag_k(self) -> float:
        """Drag acceleration coefficient rho S_FP / (2 m) [1/m]."""
        return 0.5 * self.rho * self.flat_plate_area / self.mass

    @property
    def max_horizontal_accel(self) -> float:
        return self.g * math.tan(math.radians(self.max_tilt_deg))

    @property
    def max_wind_hold(self) -> float:
        """Largest wind speed in which the vehicle can hold position [m/s]:
        drag at full lean equals the thrust's horizontal component, k W^2 = g tan(theta_max)."""
        return math.sqrt(self.max_horizontal_accel / self.drag_k)


@dataclass
class Dynamics:
    params: DynamicsParams = field(default_factory=DynamicsParams)
    #: uavsim.kernels.Kernels to run the flying sub-steps with (default: kernels.load())
    kernels: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        p = self.params
        self._fly = (self.kernels or _kernels.load()).make_fly()
        self._kparams = self._kernel_params()
        #: the parameters as native doubles for the compiled FMU step (_dynamics_ext.c), which reads them in place:
        #: uavsim.kernels' parameter slots, then preflight_time and g
        self.step_constants = struct.pack(f"{len(self._kparams) + 2}d", *self._kparams, p.preflight_time, p.g)
        #: step size -> (sub-steps, sub-step), filled by the Python step (the master's step rarely changes); the
        #: compiled step reads it and leaves a step size not in it to the Python step
        self.substep_table: dict = {}
        self.time = 0.0
        self.pos = [p.home_x, p.home_y, 0.0]
        self.vel = [0.0, 0.0, 0.0]
        self.vt = [0.0, 0.0]          # horizontal reference velocity
        self.vtz = 0.0                # vertical reference velocity
        self.integ = [0.0, 0.0]       # velocity-loop integrator (m/s^2 units after gain)
        self.phase = PREFLIGHT
        self.hold = [p.home_x, p.home_y]
        self.a_cmd = [0.0, 0.0]
        self.wind = (0.0, 0.0, 0.0)
        self.preflight_elapsed = 0.0
        self.ready = False
        self.mode = "hold"            # FLY sub-mode: "goto" (setpoint) or "hold" (position hold)
        self.hold_z = 0.0

    # ------------------------------------------------------------------ outputs
    @property
    def airspeed(self) -> float:
        """Horizontal air-relative speed |v_xy - w_xy| [m/s] (input of the Zeng power model)."""
        if self.params.wind_push:
            return math.hypot(self.vel[0], self.vel[1])
        return math.hypot(self.vel[0] - self.wind[0], self.vel[1] - self.wind[1])

    @property
    def ground_velocity(self) -> tuple[float, float, float]:
        """(east, north, up) velocity over the ground [m/s]: ``vel`` plus the push of the wind when it carries
        the vehicle (``vel`` is then relative to the air)."""
        if self.params.wind_push and self.phase in (TAKEOFF, FLY, LAND):
            return (self.vel[0] + self.wind[0], self.vel[1] + self.wind[1], self.vel[2])
        return (self.vel[0], self.vel[1], self.vel[2])

    @property
    def groundspeed(self) -> float:
        vx, vy, _ = self.ground_velocity
        return math.hypot(vx, vy)

    @property
    def tilt_deg(self) -> float:
        """Lean angle needed for the current horizontal thrust acceleration [deg]."""
        return math.degrees(math.atan2(math.hypot(*self.a_cmd), self.params.g))

    def outputs(self) -> tuple:
        """What an FMU publishes, in one call: x, y, z, the ground velocity, airspeed, groundspeed, tilt_deg,
        phase, ready (the properties above, computed by the same operations)."""
        vel, w = self.vel, self.wind
        push = self.params.wind_push
        if push and self.phase in (TAKEOFF, FLY, LAND):
            gx, gy = vel[0] + w[0], vel[1] + w[1]
        else:
            gx, gy = vel[0], vel[1]
        air = math.hypot(vel[0], vel[1]) if push else math.hypot(vel[0] - w[0], vel[1] - w[1])
        pos = self.pos
        return (pos[0], pos[1], pos[2], gx, gy, vel[2], air, math.hypot(gx, gy),
                math.degrees(math.atan2(math.hypot(*self.a_cmd), self.params.g)), int(self.phase), int(self.ready))

    # ------------------------------------------------------------------ stepping
    def _substeps(self, dt: float) -> tuple[int, float]:
        sub = self.substep_table.get(dt)
        if sub is None:
            sub = self.substep_table[dt] = self._count_substeps(dt)
        return sub

    def _count_substeps(self, dt: float) -> tuple[int, float]:
        h0 = self.params.substep
        n = max(1, int(round(dt / h0)))
        if abs(n * h0 - dt) > 1e-9 * max(1.0, dt):
            # at least one: a step far shorter than h0 (OMSimulator's last, up to the stop time) is one sub-step
            n = max(1, int(math.ceil(dt / h0 - 1e-9)))
        return n, dt / n

    def step(self, dt: float, cmd: int, sp=(0.0, 0.0, 0.0), wind=(0.0, 0.0, 0.0)) -> None:
        """Advance by ``dt`` seconds with inputs held constant (fixed internal sub-steps).

        The sub-steps are those of :meth:`_substep` (the reference implementation), run by the
        kernels of :mod:`uavsim.kernels` (same arithmetic in the same order, so bit-identical: tested);
        on the ground without a takeoff command nothing moves and the loop is skipped."""
        if dt <= 0.0:
            return
        n, h = self._substeps(dt)
        self.wind = (float(wind[0]), float(wind[1]), float(wind[2]))
        cmd = int(cmd)
        if self.phase == LANDED and cmd != CMD_TAKEOFF:
            pass                                   # on the ground: nothing changes
        elif self.phase == PREFLIGHT and cmd not in (CMD_TAKEOFF, CMD_GOTO):
            pt = self.params.preflight_time - 1e-9
            for _ in range(n):                     # only the preflight-check clock runs
                self.preflight_elapsed += h
                if self.preflight_elapsed >= pt:
                    self.ready = True
        else:
            self.run_substeps(n, h, cmd, sp)
        self.time += dt

    def step_reference(self, dt: float, cmd: int, sp=(0.0, 0.0, 0.0), wind=(0.0, 0.0, 0.0)) -> None:
        """:meth:`step` through the plain :meth:`_substep` (reference for the tests)."""
        if dt <= 0.0:
            return
        n, h = self._substeps(dt)
        self.wind = (float(wind[0]), float(wind[1]), float(wind[2]))
        for _ in range(n):
            self._substep(h, int(cmd), sp)
        self.time += dt

    def _kernel_params(self) -> tuple:
        p = self.params
        return (p.speed, p.accel, p.pos_p, p.vel_p, p.vel_i, p.accel_z, p.pos_z_p, p.speed_up, p.speed_dn,
                p.land_speed, p.land_alt_low, p.takeoff_altitude, p.drag_k, p.max_horizontal_accel,
                1.0 if p.wind_push else 0.0)

    def run_substeps(self, n: int, h: float, cmd: int, sp, i: int = 0) -> None:
        """Sub-steps i .. n-1 of :meth:`_substep`: the flying ones in the kernel (uavsim.kernels), lift-off in
        the reference code."""
        kp = self._kparams
        spx, spy, spz = float(sp[0]), float(sp[1]), float(sp[2])
        wx, wy = self.wind[0], self.wind[1]
        while i < n:
            if self.phase == PREFLIGHT or self.phase == LANDED:
                self._substep(h, cmd, sp)          # rare: lift-off happens in the reference code
                i += 1
                continue
            pos, vel, vt, integ, hold = self.pos, self.vel, self.vt, self.integ, self.hold
            s = [pos[0], pos[1], pos[2], vel[0], vel[1], vt[0], vt[1], self.vtz, integ[0], integ[1],
                 0.0, 0.0, hold[0], hold[1], self.hold_z, self.phase, 1 if self.mode == "goto" else 0, 0,
                 i, n, h, cmd, spx, spy, spz, wx, wy]
            i = self._fly(s, kp)
            (px, py, pz, vx, vy, vtx, vty, vtz, ix, iy, ax, ay, hx, hy, hold_z, phase, mode,
             landed) = s[:18]
            self.pos = [px, py, pz]
            self.vel = [vx, vy, vtz]
            self.vt = [vtx, vty]
            self.vtz = vtz
            self.integ = [ix, iy]
            self.a_cmd = [ax, ay]
            self.phase = int(phase)
            self.mode = "goto" if mode else "hold"
            self.hold = [hx, hy]
            self.hold_z = hold_z
            if landed:
                self.touch_down()

    def _set_hold_here(self):
        self.hold = [self.pos[0], self.pos[1]]

    def _substep(self, h: float, cmd: int, sp) -> None:
        p = self.params
        # ---------------- phase logic
        if self.phase == PREFLIGHT:
            self.preflight_elapsed += h
            if self.preflight_elapsed >= p.preflight_time - 1e-9:
                self.ready = True
            if self.ready and cmd in (CMD_TAKEOFF, CMD_GOTO):
                self.phase = TAKEOFF
                self._set_hold_here()
            else:
                return
        if self.phase == LANDED:
            if cmd == CMD_TAKEOFF:
                self.phase = TAKEOFF
                self._set_hold_here()
            else:
                return
        if self.phase in (TAKEOFF, FLY) and cmd == CMD_LAND:
            self.phase = LAND
            self._set_hold_here()
        # ---------------- goals
        if self.phase == FLY:
            if cmd == CMD_GOTO:
                self.mode = "goto"
            elif self.mode == "goto":      # goto released: hold where we are
                self.mode = "hold"
                self._set_hold_here()
                self.hold_z = self.pos[2]
        if self.phase == FLY and self.mode == "goto":
            gx, gy, gz = float(sp[0]), float(sp[1]), float(sp[2])
        else:
            gx, gy = self.hold
            if self.phase == TAKEOFF:
                gz = p.takeoff_altitude
            elif self.phase == FLY:
                gz = self.hold_z
            else:
                gz = self.pos[2]
        # ---------------- horizontal controller
        ex, ey = gx - self.pos[0], gy - self.pos[1]
        d = math.sqrt(ex * ex + ey * ey)
        vmag = min(p.speed, sqrt_controller(d, p.pos_p, p.accel))
        if d > 1e-9:
            vdx, vdy = vmag * ex / d, vmag * ey / d
        else:
            vdx = vdy = 0.0
        dvx, dvy = vdx - self.vt[0], vdy - self.vt[1]
        dvm = math.sqrt(dvx * dvx + dvy * dvy)
        lim = p.accel * h
        if dvm > lim:
            dvx, dvy = dvx * lim / dvm, dvy * lim / dvm
        self.vt[0] += dvx
        self.vt[1] += dvy
        aff_x, aff_y = dvx / h, dvy / h
        k = p.drag_k
        sx = math.sqrt(self.vel[0] * self.vel[0] + self.vel[1] * self.vel[1])
        evx, evy = self.vt[0] - self.vel[0], self.vt[1] - self.vel[1]
        ax = aff_x + p.vel_p * evx + p.vel_i * self.integ[0] + k * sx * self.vel[0]
        ay = aff_y + p.vel_p * evy + p.vel_i * self.integ[1] + k * sx * self.vel[1]
        amax = p.max_horizontal_accel
        am = math.sqrt(ax * ax + ay * ay)
        saturated = am > amax
        if saturated:
            ax, ay = ax * amax / am, ay * amax / am
        else:  # conditional integration (anti-windup)
            self.integ[0] += evx * h
            self.integ[1] += evy * h
        self.a_cmd = [ax, ay]
        wx, wy, wz = self.wind
        if p.wind_push:              # carried by the air: drag on the vehicle's own (air-relative) velocity
            vax, vay = self.vel[0] - 0.0, self.vel[1] - 0.0
        else:
            vax, vay = self.vel[0] - wx, self.vel[1] - wy
        va = math.sqrt(vax * vax + vay * vay)
        self.vel[0] += (ax - k * va * vax) * h
        self.vel[1] += (ay - k * va * vay) * h
        # ---------------- vertical (kinematic, acceleration-limited reference)
        ez = gz - self.pos[2]
        if self.phase == LAND:
            vzd = -(p.land_speed if self.pos[2] <= p.land_alt_low else p.speed_dn)
        else:
            vzd = math.copysign(sqrt_controller(abs(ez), p.pos_z_p, p.accel_z), ez)
            vzd = max(-p.speed_dn, min(p.speed_up, vzd))
        dvz = max(-p.accel_z * h, min(p.accel_z * h, vzd - self.vtz))
        self.vtz += dvz
        self.vel[2] = self.vtz
        # ---------------- integrate position
        if p.wind_push:
            self.pos[0] += (self.vel[0] + wx) * h
            self.pos[1] += (self.vel[1] + wy) * h
        else:
            self.pos[0] += self.vel[0] * h
            self.pos[1] += self.vel[1] * h
        self.pos[2] += self.vel[2] * h
        # ---------------- transitions
        if self.phase == TAKEOFF and self.pos[2] >= p.takeoff_altitude - 0.2:
            self.phase = FLY
            self.mode = "hold"
            self.hold_z = p.takeoff_altitude
        if self.phase == LAND and self.pos[2] <= 0.0:
            self.touch_down()

    def touch_down(self) -> None:
        """On the ground after a landing: at rest, controller state cleared."""
        self.pos[2] = 0.0
        self.vel = [0.0, 0.0, 0.0]
        self.vt = [0.0, 0.0]
        self.vtz = 0.0
        self.integ = [0.0, 0.0]
        self.a_cmd = [0.0, 0.0]
        self.phase = LANDED
