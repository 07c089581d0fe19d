"""UavWind FMU shell (pythonfmu): maps FMI variables to uavsim.wind.Wind.

Outputs at the end of a step [t, t+h] are the wind at t+h (a function of time only).
Connectors: docs/uav_connectors.md; model and parameter sources: docs/uav_models.md.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from uavsim import params as P  # noqa: E402
from uavsim.fmi import StateMixin, UnitsMixin  # noqa: E402
from uavsim.native import load_extension  # noqa: E402
from uavsim.wind import Wind, WindParams  # noqa: E402

_PARAMS = [  # name, unit, default, description
    ("probability", "1", P.WIND_PROBABILITY, "probability of wind per decision interval"),
    ("direction_deg", "deg", P.WIND_DIRECTION_DEG,
     "direction the wind comes FROM, clockwise from north (90 = from east, blows east->west)"),
    ("decision_interval", "s", P.WIND_DECISION_INTERVAL, "interval between wind draws"),
    ("duration", "s", P.WIND_DURATION, "episode duration (capped at decision_interval)"),
    ("ramp", "s", P.WIND_RAMP, "episode onset/decay ramp"),
    ("speed_weak", "m/s", P.WIND_SPEED_WEAK, "weak wind speed (Beaufort 3)"),
    ("speed_moderate", "m/s", P.WIND_SPEED_MODERATE, "moderate wind speed (Beaufort 4)"),
    ("speed_strong", "m/s", P.WIND_SPEED_STRONG, "strong wind speed (Beaufort 6)"),
    ("p_weak", "1", P.WIND_P_WEAK, "P(weak | wind)"),
    ("p_moderate", "1", P.WIND_P_MODERATE, "P(moderate | wind); P(strong) = 1 - p_weak - p_moderate"),
    ("turb_dt", "s", P.TURB_DT, "Dryden noise sample interval"),
    ("turb_altitude", "m", P.TURB_ALTITUDE, "altitude for the Dryden length scales"),
    ("gust_amplitude", "1", P.GUST_AMPLITUDE, "1-cosine gust amplitude / episode speed"),
    ("gust_length", "s", P.GUST_LENGTH, "1-cosine gust duration"),
]


class UavWind(StateMixin, UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Paper's stochastic east-to-west wind with optional Dryden turbulence and 1-cosine gusts"
    # no inputs: the wind is a function of time alone
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _PARAMS:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        self.seed = 0
        self.par_int("seed", "seed of the PCG64 generators")
        self.stream = -1
        self.par_int("stream", "-1: one wind for the fleet; i >= 0: UAV i's own draw from the same seed")
        self.turbulence = False
        self.par_bool("turbulence", "enable Dryden turbulence")
        self.gusts = False
        self.par_bool("gusts", "enable discrete 1-cosine gusts")
        self.step_mean = True
        self.par_bool("step_mean", "output the mean wind over the coming step (true) or the wind at the "
                                   "communication point (false)")
        for name, desc in [("wind_x", "air velocity east"), ("wind_y", "air velocity north"),
                           ("wind_z", "air velocity up"), ("wind_speed", "horizontal wind speed")]:
            setattr(self, name, 0.0)
            self.out_real(name, "m/s", desc)
        self.wind_level = 0
        self.out_int("wind_level", "0 none, 1 weak, 2 moderate, 3 strong")
        self._model = None
        self._t = 0.0
        ext = load_extension("_wind_ext", os.path.join(_HERE, "uavsim"))
        self._ext = None if ext is None else ext.step   # the whole step in C, or None: the Python code below

    @property
    def model(self):
        """The uavsim model this shell steps (None before initialisation), for tests and tools that read or set
        its state."""
        return self._model

    def _build(self):
        kw = {n: getattr(self, n) for n, *_ in _PARAMS}
        self._model = Wind(WindParams(seed=int(self.seed), stream=int(self.stream), turbulence=bool(self.turbulence),
                                      gusts=bool(self.gusts), **kw))

    def setup_experiment(self, start_time, stop_time, tolerance):
        self._t = float(start_time or 0.0)

    def exit_initialization_mode(self):
        self._build()
        self._publish(self._t)

    def _publish(self, t, h=0.0):
        # with step_mean the output held over [t, t + h] is the wind's mean over that interval, assuming
        # the next step is as long as the last one (fixed-step masters); at initialization h is unknown
        if self.step_mean and h > 0.0:
            wx, wy, wz, lvl = self._model.mean_over(t, t + h)
        else:
            wx, wy, wz, lvl = self._model.at(t)
        self.wind_x, self.wind_y, self.wind_z = wx, wy, wz
        self.wind_speed = (wx * wx + wy * wy) ** 0.5
        self.wind_level = int(lvl)

    def do_step(self, current_time, step_size):
        ext = self._ext
        # the compiled step (uavsim/_wind_ext.c) does this whole step (same results, bit for bit) on the model and the
        # FMU's variables (this instance's variable values), or, when it returns False (a random draw, turbulence,
        # no model yet ...), nothing
        if ext is not None and ext(self._model, self.__dict__, current_time, step_size):
            return True
        if self._model is None:
            self._build()
        self._publish(current_time + step_size, step_size)
        return True
