"""UavStrategy FMU shell (pythonfmu): maps FMI variables to uavsim.strategy.Strategy.

On do_step(t, h) the logic is evaluated on the inputs sampled at t (photo times are t); the new
commands are the outputs for the next step.  The step is Strategy.step, or its compiled twin
(uavsim/_strategy_ext.c, declared in uavsim/strategy_accel.py) when it is built and not switched off.
Connectors: docs/uav_connectors.md; model and parameter sources: docs/uav_models.md.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:           # inside the FMU this is resources/, which holds uavsim/
    sys.path.insert(0, _HERE)

from pythonfmu import Fmi2Slave  # noqa: E402

from uavsim import mission_encoding as M  # noqa: E402
from uavsim import native  # noqa: E402
from uavsim import cooperative_fmi  # noqa: E402
from uavsim import params as P  # noqa: E402
from uavsim.fmi import StateMixin, UnitsMixin  # noqa: E402
from uavsim.strategy import Strategy, StrategyParams  # noqa: E402

_REAL = [  # name, unit, default, description
    ("lookahead", "m", P.LOOKAHEAD, "restricted-zone look-ahead distance"),
    ("home_x", "m", 0.0, "base east position"),
    ("home_y", "m", 0.0, "base north position"),
    ("cruise_altitude", "m", P.CRUISE_ALTITUDE, "flight altitude"),
    ("return_threshold", "1", P.RETURN_THRESHOLD, "consumed fraction: return to base"),
    ("land_threshold", "1", P.LAND_THRESHOLD, "consumed fraction: land immediately"),
    ("arrival_radius", "m", P.ARRIVAL_RADIUS, "target / waypoint acceptance radius"),
    ("avoid_margin", "m", P.AVOID_MARGIN, "outward offset of the reactive detour vertices (zone_planning false)"),
    ("plan_margin", "m", P.PLAN_MARGIN, "clearance of planned legs from the zones (zone_planning true)"),
    ("lane_spacing", "m", P.LANE_SPACING, "extra planning clearance per UAV index (detour lanes)"),
    ("brake_accel", "m/s2", P.WP_ACCEL, "deceleration assumed for the safety-net stopping distance"),
]
_STR = [
    ("strategy", "A", "A: defined order, B: nearest remaining target first, C: B plus the channel's messages"),
    ("assignment", "equal", "equal (contiguous blocks), roundrobin (k mod N) or spatial (sectors)"),
    ("targets", "", "targets 'x1,y1;x2,y2;...' ENU m (used when n_targets = -1)"),
    ("zones", "", "restricted zones: polygons separated by '|', vertices 'x,y' separated by ';' "
                  "(used when n_zones = -1)"),
]
#: the compiled step (uavsim/_strategy_ext.c): does the steps in which nothing happens (on the strategy's
#: MissionState and this FMU's variables) and declines, changing nothing, all others; None: Python does every step
_EXT = native.load_extension("_strategy_ext", os.path.join(_HERE, "uavsim"))
_FAST_STEP = _EXT.step if _EXT is not None else None

_INDEXED_DESCRIPTIONS = {  # docs/uav_models.md, "Mission data as indexed parameters"
    "n_targets": f"number of targets target_x_k/target_y_k (0..{M.MAX_TARGETS}); -1: use the String 'targets'",
    "n_zones": f"number of zones zone_z_* (0..{M.MAX_ZONES}); -1: use the String 'zones'",
}

# the indexed parameters' names and start values: set in one update by every instance after the first (a
# thousand one-by-one registrations were the costliest part of a campaign run's FMU instantiation)
_INDEXED_DEFAULTS = {name: (M.NOT_GIVEN if name in _INDEXED_DESCRIPTIONS else 0) if typ == "Integer" else 0.0
                     for name, typ in M.parameter_names()}
_INDEXED_NAMES = tuple(_INDEXED_DEFAULTS)


class UavStrategy(StateMixin, UnitsMixin, Fmi2Slave):
    author = "cosim-master"
    description = "Surveillance mission logic of one UAV (paper's Strategy A / B)"
    # no direct feedthrough: the commands and counters are decided in doStep, from the inputs at its start
    output_dependencies: dict = {}

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        for name, unit, default, desc in _REAL:
            setattr(self, name, float(default))
            self.par_real(name, unit, desc)
        for name, default, desc in _STR:
            setattr(self, name, default)
            self.par_str(name, desc)
        self._register_indexed_mission()
        self.zone_planning = True
        self.par_bool("zone_planning", "plan every leg around the zones (false: the paper's late 2 m detection)")
        self.uav_index = 0
        self.par_int("uav_index", "index of this UAV, 0..uav_count-1")
        self.uav_count = 1
        self.par_int("uav_count", "number of UAVs sharing the targets")
        for name, unit, desc in [("x", "m", "east position"), ("y", "m", "north position"),
                                 ("z", "m", "up position"), ("vx", "m/s", "east velocity"),
                                 ("vy", "m/s", "north velocity"),
                                 ("consumed", "1", "battery fraction consumed")]:
            setattr(self, name, 0.0)
            self.in_real(name, unit, desc)
        self.phase = 0
        self.in_int("phase", "vehicle phase")
        self.command = 0
        self.in_int("command", "ground-station command, taken when it changes: 0 none, 1 return to base, 2 land")
        self.cmd = 1
        self.out_int("cmd", "0 idle/hold, 1 takeoff, 2 goto setpoint, 3 land")
        for name, desc in [("sp_x", "setpoint east"), ("sp_y", "setpoint north"), ("sp_z", "setpoint up")]:
            setattr(self, name, 0.0)
            self.out_real(name, "m", desc)
        for name, desc in [("mission_state", "see docs/uav_models.md"),
                           ("targets_assigned", "number of targets assigned to this UAV"),
                           ("targets_visited", "number of assigned targets photographed"),
                           ("photo_count", "photos taken"),
                           ("last_photo_target", "global index of the last photographed target (-1 none)"),
                           ("current_target", "global index of the target being flown to (-1 none)"),
                           ("avoiding", "1 while flying a zone detour (or braking before a zone)"),
                           ("avoid_count", "number of detours planned plus safety-net brakes")]:
            setattr(self, name, 0)
            self.out_int(name, desc)
        self.last_photo_target = -1
        self.current_target = -1
        for name, unit, desc in [("last_photo_time", "s", "time of the last photo"),
                                 ("last_photo_x", "m", "east position of the last photo"),
                                 ("last_photo_y", "m", "north position of the last photo")]:
            setattr(self, name, 0.0)
            self.out_real(name, unit, desc)
        cooperative_fmi.register(self)
        self._model = None

    def _register_indexed_mission(self):
        """The targets and zones as scalar Integer/Real parameters (uavsim/mission_encoding.py), which
        every master applies (not all apply String parameters)."""
        if self._run_in_table(_INDEXED_NAMES):      # a later instance: the class's first one registered them
            self.__dict__.update(_INDEXED_DEFAULTS)
            return
        for name, typ in M.parameter_names():
            if typ == "Integer":
                default = M.NOT_GIVEN if name in _INDEXED_DESCRIPTIONS else 0
                setattr(self, name, default)
                self.par_int(name, _INDEXED_DESCRIPTIONS.get(name, "vertex count of this zone"))
            else:
                setattr(self, name, 0.0)
                self.par_real(name, "m", "ENU coordinate (mission data, see n_targets / n_zones)")

    def _mission(self) -> dict:
        """targets and zones for StrategyParams: the indexed form where given (it wins: every master
        applies it), else the String form."""
        get = self.__getattribute__
        targets, zones = M.decode_targets(get), M.decode_zones(get)
        return {"targets": str(self.targets) if targets is None else targets,
                "zones": str(self.zones) if zones is None else zones}

    def _build(self):
        kw = {n: getattr(self, n) for n, *_ in _REAL}
        kw.update({n: str(getattr(self, n)) for n, *_ in _STR})
        kw.update(self._mission())
        params = StrategyParams(uav_index=int(self.uav_index), uav_count=int(self.uav_count),
                                zone_planning=bool(self.zone_planning), **kw)
        self._model = cooperative_fmi.make(self, params) if params.strategy.strip().upper() == "C" \
            else Strategy(params)

    def exit_initialization_mode(self):
        self._build()
        self._publish()

    def _publish(self):
        (self.cmd, self.sp_x, self.sp_y, self.sp_z, self.mission_state, self.targets_assigned, self.targets_visited,
         self.photo_count, self.last_photo_target, self.current_target, self.avoiding, self.avoid_count,
         self.last_photo_time, self.last_photo_x, self.last_photo_y) = self._model.outputs()

    def do_step(self, current_time, step_size):
        model = self._model
        if model is None:
            self._build()
            model = self._model
        if model.kind == "C":
            cooperative_fmi.step(self, model, current_time, step_size, _FAST_STEP)
            return True
        # the compiled step reads the inputs from and writes the outputs to this FMU's variables, by their names
        if _FAST_STEP is not None and _FAST_STEP(model.step_constants, model.mission, self.__dict__):
            return True
        model.step(current_time, self.x, self.y, self.z, self.vx, self.vy, int(self.phase), self.consumed,
                   self.command)
        self._publish()
        return True
