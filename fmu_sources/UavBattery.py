"""UavBattery FMU shell (pythonfmu): maps FMI variables to uavsim.battery.Battery.

Connectors: docs/uav_connectors.md; model and parameter sources: docs/uav_models.md.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from uavsim import params as P  # noqa: E402
from uavsim.battery import Battery, BatteryParams, PowerParams  # noqa: E402
from uavsim.fmi import StateMixin, UnitsMixin  # noqa: E402
from uavsim.kernels import load as load_kernels  # noqa: E402
from uavsim.native import load_extension  # noqa: E402

_POWER = [  # name, unit, default, description  (PowerParams fields)
    ("mass", "kg", P.MASS, "take-off mass"),
    ("rho", "kg/m3", P.RHO_SL, "air density"),
    ("rotor_radius", "m", P.ROTOR_RADIUS, "rotor radius"),
    ("solidity", "1", P.ROTOR_SOLIDITY, "rotor solidity s"),
    ("tip_speed", "m/s", P.TIP_SPEED, "blade tip speed in hover, Omega R"),
    ("profile_drag_coef", "1", P.PROFILE_DRAG_COEF, "blade profile drag coefficient delta (Zeng 2019)"),
    ("induced_correction", "1", P.INDUCED_CORRECTION, "induced power correction k (Zeng 2019)"),
    ("flat_plate_area", "m2", P.FLAT_PLATE_AREA, "fuselage equivalent flat-plate area d0 s A"),
    ("efficiency", "1", P.PROPULSION_EFFICIENCY, "shaft-to-electrical propulsion efficiency"),
    ("avionics_power", "W", P.AVIONICS_POWER, "constant avionics/payload power"),
]
_BATT = [  # BatteryParams fields
    ("capacity_ah", "Ah", P.CAPACITY_AH, "rated capacity"),
    ("cell_resistance", "Ohm", P.CELL_RESISTANCE, "internal resistance per cell"),
    ("initial_soc", "1", 1.0, "state of charge at t = 0"),
    ("substep", "s", P.BATTERY_SUBSTEP, "coulomb-counting sub-step"),
]


class UavBattery(StateMixin, UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "3S LiPo battery with Zeng et al. (2019) rotary-wing propulsion power"
    # no direct feedthrough: the outputs are published from the state in exitInitializationMode and doStep
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _POWER + _BATT:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        self.rotor_count = P.ROTOR_COUNT
        self.par_int("rotor_count", "number of rotors")
        self.cells = P.CELLS
        self.par_int("cells", "series cell count")
        self.airspeed = 0.0
        self.in_real("airspeed", "m/s", "horizontal airspeed")
        self.vz = 0.0
        self.in_real("vz", "m/s", "vertical (up) velocity")
        self.phase = 0
        self.in_int("phase", "vehicle phase; motors run in 1 takeoff, 2 fly, 3 land")
        for name, unit, desc in [("soc", "1", "state of charge"),
                                 ("consumed", "1", "fraction of the capacity consumed"),
                                 ("voltage", "V", "terminal voltage"), ("current", "A", "current"),
                                 ("power", "W", "electrical power"),
                                 ("energy_used", "J", "electrical energy delivered since t = 0")]:
            setattr(self, name, 0.0)
            self.out_real(name, unit, desc)
        self.depleted = 0
        self.out_int("depleted", "1 when consumed >= 1")
        self._model = None
        self._build()
        self._publish()

    @property
    def model(self):
        """The uavsim model this shell steps (None before initialisation), for tests and tools that read or set
        its state."""
        return self._model

    def _build(self):
        pk = {n: getattr(self, n) for n, *_ in _POWER}
        bk = {n: getattr(self, n) for n, *_ in _BATT}
        self._model = Battery(PowerParams(rotor_count=int(self.rotor_count), **pk),
                              BatteryParams(cells=int(self.cells), **bk),
                              kernels=load_kernels(os.path.join(_HERE, "uavsim")))
        ext = load_extension("_battery_ext", os.path.join(_HERE, "uavsim"))
        self._ext = None if ext is None else ext.step   # the whole step in C, or None: the Python code below

    def exit_initialization_mode(self):
        self._build()
        self._publish()

    def _publish(self):
        m = self._model
        self.soc, self.consumed = m.soc, m.consumed
        self.voltage, self.current, self.power = m.voltage, m.current, m.power
        self.energy_used = m.energy_used
        self.depleted = int(m.depleted)

    def do_step(self, current_time, step_size):
        ext = self._ext
        # the compiled step (uavsim/_battery_ext.c) does this whole step (same results, bit for bit) on the model and
        # the FMU's variables (this instance's variable values), or, when it returns False, nothing
        if ext is not None and ext(self._model, self.__dict__, step_size):
            return True
        out = self._model.step_outputs(step_size, self.airspeed, self.vz, int(self.phase))
        if out is not None:       # the model's step returns what _publish would read from it
            (self.soc, self.consumed, self.voltage, self.current, self.power, self.energy_used,
             self.depleted) = out
        return True
