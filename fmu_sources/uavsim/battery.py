"""Rotary-wing propulsion power (Zeng, Xu, Zhang 2019) and a LiPo battery (coulomb counting,
open-circuit-voltage table, internal resistance).

Propulsion shaft power at horizontal airspeed V [ZENG eq. (12)]:

    P_shaft(V) = P0 (1 + 3 V^2 / U_tip^2)
               + Pi sqrt( sqrt(1 + V^4 / (4 v0^4)) - V^2 / (2 v0^2) )
               + 0.5 d0 rho s A V^3

with, for the whole vehicle (all rotors), A = n_rotors pi R^2 the total disc area,
s the rotor solidity, W = m g,
    P0 = delta/8 rho s A U_tip^3          (blade profile power in hover)
    Pi = (1 + k) W^1.5 / sqrt(2 rho A)    (induced power in hover)
    v0 = sqrt(W / (2 rho A))              (mean induced velocity in hover)
    d0 s A = S_FP                          (fuselage equivalent flat-plate area, the same S_FP as
                                            the drag of the dynamics model).

Electrical power drawn from the pack:

    P = P_shaft(V) / eta + max(0, m g v_z) / eta + P_avionics     (motors running: phases 1-3)
    P = P_avionics                                                  (on ground: phases 0 and 4)

Battery: E = n_cells * OCV(soc) (linear interpolation in a per-cell table), terminal voltage
U = E - I R; the current follows from P = U I = E I - R I^2:

    I = (E - sqrt(E^2 - 4 R P)) / (2 R)           (I = P / E when R = 0)

(if E^2 < 4 R P the pack cannot deliver P; the current is then capped at the maximum-power
current E / (2R) and ``overload`` is set).  Coulomb counting: dQ/dt = I,
consumed = Q / C, soc = 1 - consumed (clamped at 0), energy_used = integral of U I dt.

This module is the reference: the plain code a reader follows and changes (:meth:`Battery.step_reference`, the
power and battery functions above).  Its accelerators compute exactly the same, faster: the step's loop runs in
:mod:`uavsim.kernels` (``battery_step_py``, compiled as kernels.c) and the UavBattery FMU's whole step in
uavsim/_battery_ext.c, which reads and sets the public fields of :class:`Battery`; both are declared in
uavsim/accelerators.py and checked against this code by the accelerator harness (``COSIM_MASTER_PURE_PYTHON=1``
switches them off).
"""
from __future__ import annotations

import bisect
import math
import struct
from dataclasses import dataclass, field

from . import kernels as _kernels
from . import params as P


@dataclass
class PowerParams:
    mass: float = P.MASS                          # kg
    rho: float = P.RHO_SL                         # kg/m^3
    g: float = P.G0                               # m/s^2
    rotor_count: int = P.ROTOR_COUNT
    rotor_radius: float = P.ROTOR_RADIUS          # m
    solidity: float = P.ROTOR_SOLIDITY            # 1
    tip_speed: float = P.TIP_SPEED                # m/s
    profile_drag_coef: float = P.PROFILE_DRAG_COEF  # 1 (delta)
    induced_correction: float = P.INDUCED_CORRECTION  # 1 (k)
    flat_plate_area: float = P.FLAT_PLATE_AREA    # m^2 (d0 s A)
    efficiency: float = P.PROPULSION_EFFICIENCY   # 1
    avionics_power: float = P.AVIONICS_POWER      # W

    @property
    def disc_area(self) -> float:
        return self.rotor_count * math.pi * self.rotor_radius ** 2

    @property
    def weight(self) -> float:
        return self.mass * self.g

    @property
    def p0(self) -> float:
        return self.profile_drag_coef / 8.0 * self.rho * self.solidity * self.disc_area * self.tip_speed ** 3

    @property
    def pi(self) -> float:
        return (1.0 + self.induced_correction) * self.weight ** 1.5 / math.sqrt(2.0 * self.rho * self.disc_area)

    @property
    def v0(self) -> float:
        return math.sqrt(self.weight / (2.0 * self.rho * self.disc_area))


def shaft_power(v: float, p: PowerParams) -> float:
    """Zeng et al. (2019) eq. (12): propulsion (shaft) power at horizontal airspeed v [W]."""
    v2 = v * v
    v0 = p.v0
    blade = p.p0 * (1.0 + 3.0 * v2 / p.tip_speed ** 2)
    induced = p.pi * math.sqrt(max(0.0, math.sqrt(1.0 + v2 * v2 / (4.0 * v0 ** 4)) - v2 / (2.0 * v0 * v0)))
    parasite = 0.5 * p.rho * p.flat_plate_area * v2 * abs(v)
    return blade + induced + parasite


def electrical_power(airspeed: float, vz: float, motors_on: bool, p: PowerParams) -> float:
    """Electrical power drawn from the pack [W]."""
    if not motors_on:
        return p.avionics_power
    climb = max(0.0, p.weight * vz)
    return (shaft_power(airspeed, p) + climb) / p.efficiency + p.avionics_power


def power_function(p: PowerParams):
    """:func:`electrical_power` for fixed parameters ``p``, with the constant sub-expressions evaluated
    once (same operations in the same order, so the same results bit for bit: tested)."""
    v0 = p.v0
    p0, pi, eff, avionics, weight = p.p0, p.pi, p.efficiency, p.avionics_power, p.weight
    tip2, v0_4x4, v0_2x2 = p.tip_speed ** 2, 4.0 * v0 ** 4, 2.0 * v0 * v0
    drag = 0.5 * p.rho * p.flat_plate_area
    sqrt = math.sqrt

    def power(airspeed: float, vz: float, motors_on: bool) -> float:
        if not motors_on:
            return avionics
        v2 = airspeed * airspeed
        blade = p0 * (1.0 + 3.0 * v2 / tip2)
        induced = pi * sqrt(max(0.0, sqrt(1.0 + v2 * v2 / v0_4x4) - v2 / v0_2x2))
        shaft = blade + induced + drag * v2 * abs(airspeed)
        return (shaft + max(0.0, weight * vz)) / eff + avionics
    return power


def _power_slots(p: PowerParams) -> tuple:
    """The constants of :func:`power_function` in the kernels' power slots (uavsim.kernels W_*)."""
    v0 = p.v0
    return (p.p0, p.tip_speed ** 2, p.pi, 4.0 * v0 ** 4, 2.0 * v0 * v0, 0.5 * p.rho * p.flat_plate_area,
            p.weight, p.efficiency, p.avionics_power)


_MOTORS_ON = (1, 2, 3)


@dataclass
class BatteryParams:
    cells: int = P.CELLS
    capacity_ah: float = P.CAPACITY_AH            # Ah
    cell_resistance: float = P.CELL_RESISTANCE    # ohm
    initial_soc: float = 1.0                      # 1
    ocv_soc: tuple = P.OCV_SOC
    ocv_cell: tuple = P.OCV_CELL                  # V per cell
    substep: float = P.BATTERY_SUBSTEP            # s

    @property
    def resistance(self) -> float:
        return self.cells * self.cell_resistance

    @property
    def capacity_c(self) -> float:
        return self.capacity_ah * 3600.0


def ocv_cell(soc: float, bp: BatteryParams) -> float:
    xs, ys = bp.ocv_soc, bp.ocv_cell
    if soc <= xs[0]:
        return ys[0]
    if soc >= xs[-1]:
        return ys[-1]
    i = bisect.bisect_right(xs, soc) - 1
    f = (soc - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + f * (ys[i + 1] - ys[i])


def current_for_power(power: float, emf: float, r: float) -> tuple[float, bool]:
    """Current I drawn at electrical power ``power`` from a source emf - r I. Returns (I, overload)."""
    if r <= 0.0:
        return power / emf, False
    disc = emf * emf - 4.0 * r * power
    if disc < 0.0:
        return emf / (2.0 * r), True
    return (emf - math.sqrt(disc)) / (2.0 * r), False


@dataclass
class Battery:
    power_params: PowerParams = field(default_factory=PowerParams)
    params: BatteryParams = field(default_factory=BatteryParams)
    #: uavsim.kernels.Kernels to count with (default: kernels.load())
    kernels: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        bp = self.params
        self._step = (self.kernels or _kernels.load()).make_battery_step()
        self._kparams = (*_power_slots(self.power_params), float(bp.cells), bp.resistance, bp.capacity_c,
                         float(len(bp.ocv_soc)), *map(float, bp.ocv_soc), *map(float, bp.ocv_cell))
        #: the parameters as native doubles (uavsim.kernels' power slots, then its battery slots), which the
        #: compiled step (_battery_ext.c) reads in place
        self.step_constants = struct.pack(f"{len(self._kparams)}d", *self._kparams)
        #: step size -> (sub-steps, sub-step), filled by the Python step (the master's step rarely changes); the
        #: compiled step reads it and leaves a step size not in it to the Python step
        self.substep_table: dict = {}
        self.charge_used = (1.0 - bp.initial_soc) * bp.capacity_c   # C
        self.energy_used = 0.0                                        # J
        self.power = 0.0
        self.current = 0.0
        self.overload = False
        self.voltage = bp.cells * ocv_cell(self.soc, bp)
        self._update(0.0, 0.0, False)

    @property
    def consumed(self) -> float:
        return self.charge_used / self.params.capacity_c

    @property
    def soc(self) -> float:
        return max(0.0, 1.0 - self.consumed)

    @property
    def depleted(self) -> bool:
        return self.consumed >= 1.0

    def _update(self, airspeed, vz, motors_on):
        self._update_power(electrical_power(airspeed, vz, motors_on, self.power_params))

    def _update_power(self, demand: float) -> None:
        """Current, terminal voltage and delivered power for the electrical power ``demand``."""
        bp = self.params
        emf = bp.cells * ocv_cell(self.soc, bp)
        self.power = demand
        self.current, self.overload = current_for_power(demand, emf, bp.resistance)
        self.voltage = emf - self.current * bp.resistance
        self.power = self.voltage * self.current

    def _substeps(self, dt: float) -> tuple[int, float]:
        h0 = self.params.substep
        n = max(1, int(round(dt / h0)))
        if abs(n * h0 - dt) > 1e-9 * max(1.0, dt):
            # at least one: a step far shorter than h0 (OMSimulator's last, up to the stop time) is one sub-step
            n = max(1, int(math.ceil(dt / h0 - 1e-9)))
        return n, dt / n

    def step_reference(self, dt: float, airspeed: float, vz: float, phase: int) -> None:
        """:meth:`step` written plainly (reference for the tests)."""
        if dt <= 0.0:
            return
        motors_on = int(phase) in (1, 2, 3)
        n, h = self._substeps(dt)
        for _ in range(n):
            self._update(airspeed, vz, motors_on)
            self.charge_used += self.current * h
            self.energy_used += self.power * h
        self._update(airspeed, vz, motors_on)

    def step(self, dt: float, airspeed: float, vz: float, phase: int) -> None:
        """Advance by ``dt`` with the inputs held: coulomb counting on fixed sub-steps.

        Same arithmetic as :meth:`step_reference` (bit-identical, tested), with the power demand
        computed once (the inputs are held over the step); power, sub-step loop and the published outputs
        are one call of the kernels of :mod:`uavsim.kernels`."""
        self.step_outputs(dt, airspeed, vz, phase)

    def step_outputs(self, dt: float, airspeed: float, vz: float, phase: int):
        """:meth:`step`, returning what an FMU publishes: (soc, consumed, voltage, current, power, energy_used,
        depleted as 0/1), or None when ``dt`` <= 0 (nothing changed)."""
        if dt <= 0.0:
            return None
        sub = self.substep_table.get(dt)
        if sub is None:
            sub = self.substep_table[dt] = self._substeps(dt)
        s = [self.charge_used, self.energy_used, 0.0, 0.0, 0.0, 0.0, sub[0], sub[1], 0.0, float(airspeed), float(vz),
             1.0 if int(phase) in _MOTORS_ON else 0.0, 0.0, 0.0, 0.0]
        self._step(s, self._kparams)
        q, e, cur, over, volt, pw, _, _, _, _, _, _, cons, soc, depl = s
        self.charge_used, self.energy_used = q, e
        self.current, self.overload, self.voltage, self.power = cur, over != 0.0, volt, pw
        return soc, cons, volt, cur, pw, e, int(depl)
