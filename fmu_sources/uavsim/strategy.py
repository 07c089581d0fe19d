"""Mission logic of one UAV: the state machine that flies the assigned targets, takes the photos, applies the
battery rules and goes around the restricted zones.

Its parts live beside it: which targets and in which order (Strategies A and B) in uavsim/assignment.py, the zone
geometry and the paths planned around the zones in uavsim/zones_planning.py.  What a step changes is one declared
structure, :class:`MissionState`; :meth:`Strategy.step` is the FMU's step on it in plain Python, the reference
that the compiled step (uavsim/_strategy_ext.c, declared in uavsim/strategy_accel.py) must match bit for bit.

Battery rules (the paper): consumed >= return_threshold (0.8) -> abandon the mission and return to
base; consumed >= land_threshold (0.95) -> land immediately where the UAV is.

Restricted zones, ``zone_planning`` true (default): every leg (to a target, or home to the pad) is
planned when it starts (i.e. whenever the goal changes): the shortest path from the position to the
goal in a visibility graph whose nodes are the vertices of the zones offset outward by the margin
m = ``plan_margin`` + ``lane_spacing`` * uav_index (plan_margin 20 m = V^2/(2 A), the braking
distance at cruise speed; 5 m lanes, so that UAVs going round the same corner do not converge on
one vertex; mitred) and whose edges keep at least m from every zone.  An edge that starts or ends
at a point with a smaller clearance c (the UAV itself, a target close to a zone) needs only min(m, 0.9 c),
so such a target is approached along the shortest free path with a reduced margin; if there is
no path the margin is halved (down to 1/16) before giving up (then straight to the goal).  The path
vertices are flown as intermediate waypoints (accepted within arrival_radius).  Last-resort safety
net (wind drift): each step the segment from the position along the velocity (groundspeed >
0.5 m/s) of length min(lookahead + v^2/(2 brake_accel), distance to the waypoint) is tested
against the zones; on a hit the UAV brakes (setpoint = where it is) until its groundspeed is below
0.5 m/s, then re-plans from there.  The leg is also re-planned when the straight line to the next
waypoint crosses a zone.

Restricted zones, ``zone_planning`` false (the paper's late detection, collision-prone): every step
two segments of length ``lookahead`` from the current position are tested against the zone
polygons: one along the current flight direction (the velocity direction, when the groundspeed
exceeds 0.5 m/s) and one toward the current goal (the commanded leg).  On a hit the UAV plans a
fly-around: the shortest path from its position to the goal in the visibility graph whose nodes are
the vertices of every zone offset outward by ``avoid_margin`` (mitred buffer), and whose edges
keep at least avoid_margin/2 from every zone (an edge from the UAV's position, or to a goal, that
lies closer than that only has to avoid the zone itself).  Going around the side where the path is shorter is thus
automatic.  The detour vertices are flown as intermediate waypoints (accepted within
arrival_radius); while detouring, a re-plan happens only if the leg to the next detour vertex is
itself blocked.  If no path exists (e.g. the UAV is already inside a zone) it flies straight on.

mission_state codes:
  0 PREFLIGHT      waiting for the vehicle (phase 0), cmd = 1 (takeoff request)
  1 TAKEOFF        climbing (phase 1), cmd = 1
  2 TRANSIT        flying to the current target, cmd = 2
  3 RETURN_DONE    all assigned targets visited, flying back to base, cmd = 2
  4 RETURN_LOW     consumed >= return_threshold, mission abandoned, flying to base, cmd = 2
  5 LAND_BASE      over the base, landing, cmd = 3
  6 LAND_NOW       consumed >= land_threshold away from base: immediate landing, cmd = 3
  7 LANDED_BASE    on the ground at the base (final)
  8 LANDED_AWAY    on the ground away from the base (final; forced landing)
  9 RETURN_CMD     a ground station commanded the return to base (``command``), cmd = 2
 10 LAND_CMD       a ground station commanded a landing where the UAV is (``command``), cmd = 3

Ground-station commands (``Strategy.command``; the FMU's Integer input ``command``: 0 none, 1 return to
base, 2 land) are taken when the input changes; the strategy stays the one owner of the mission logic:
a return is accepted while flying a mission leg (TRANSIT, RETURN_DONE), a landing while airborne and
not landing yet; otherwise the command is ignored (the ground station sees the state unchanged).
"""
from __future__ import annotations

import math
from array import array
from dataclasses import dataclass

from . import params as P
# the names the FMU shell, uavstudy and the tests have always imported from here
from .assignment import as_points, assign_targets, next_target, parse_points  # noqa: F401
from .zones_planning import ZoneMap, ZonePlanner, as_zones, parse_zones, zone_record  # noqa: F401

PREFLIGHT, TAKEOFF, TRANSIT, RETURN_DONE, RETURN_LOW, LAND_BASE, LAND_NOW, LANDED_BASE, LANDED_AWAY = range(9)
RETURN_CMD, LAND_CMD = 9, 10
STATE_NAMES = ["PREFLIGHT", "TAKEOFF", "TRANSIT", "RETURN_DONE", "RETURN_LOW", "LAND_BASE",
               "LAND_NOW", "LANDED_BASE", "LANDED_AWAY", "RETURN_CMD", "LAND_CMD"]
#: values of the ``command`` input
COMMAND_NONE, COMMAND_RETURN, COMMAND_LAND = 0, 1, 2
#: the FMU's outputs, in the order of :meth:`Strategy.outputs`
OUTPUT_NAMES = ("cmd", "sp_x", "sp_y", "sp_z", "mission_state", "targets_assigned", "targets_visited",
                "photo_count", "last_photo_target", "current_target", "avoiding", "avoid_count", "last_photo_time",
                "last_photo_x", "last_photo_y")


@dataclass
class StrategyParams:
    strategy: str = "A"
    uav_index: int = 0
    uav_count: int = 1
    assignment: str = "equal"
    targets: str | list = ""                    # String form or [(x, y), ...]
    zones: str | list = ""                      # String form or [[(x, y), ...], ...]
    lookahead: float = P.LOOKAHEAD              # m
    home_x: float = 0.0                         # m
    home_y: float = 0.0                         # m
    cruise_altitude: float = P.CRUISE_ALTITUDE  # m
    return_threshold: float = P.RETURN_THRESHOLD  # 1
    land_threshold: float = P.LAND_THRESHOLD    # 1
    arrival_radius: float = P.ARRIVAL_RADIUS    # m
    avoid_margin: float = P.AVOID_MARGIN        # m (paper's reactive detour)
    zone_planning: bool = True                  # plan every leg around the zones
    plan_margin: float = P.PLAN_MARGIN          # m clearance of planned legs
    lane_spacing: float = P.LANE_SPACING        # m extra clearance per UAV index (lanes)
    brake_accel: float = P.WP_ACCEL             # m/s^2 deceleration for the safety-net look-ahead


class MissionState:
    """Everything a step of the mission reads and may change; the rest of a Strategy is fixed when it is built.

    The compiled step (uavsim/_strategy_ext.c) reads and writes these fields by these names: they are its
    interface, so a field renamed here must be renamed there (it raises AttributeError otherwise, which the
    accelerator harness reports).  Points are (x, y) tuples of floats, ENU m.

    ``state``            mission_state code (module docstring)
    ``cmd``              vehicle command: 1 takeoff, 2 go to the setpoint, 3 land
    ``sp``               setpoint (x, y, z)
    ``current_target``   global index of the target flown to, -1 none
    ``remaining``        assigned targets not photographed yet (map order)
    ``visited``          targets photographed, in the order they were
    ``photos``           (target, t, x, y) of every photo
    ``photo_count``, ``last_photo_target``, ``last_photo_time``, ``last_photo_x``, ``last_photo_y``
    ``avoid_count``      detours planned plus safety-net brakes
    ``detour``           zone_planning false: the reactive detour's vertices left, ending with the goal ([] none)
    ``path``             zone_planning true: the planned leg's waypoints left, ending with the goal
    ``path_goal``        the goal ``path`` was planned for (None: no leg planned yet)
    ``plan_count``       legs planned (with or without detour vertices)
    ``brake_count``      safety-net brakes
    ``braking``          braking before a zone (True/False) at ``brake_point``
    ``command_taken``    the last ground-station command taken (the input is acted on when it changes)
    """
    __slots__ = ("state", "cmd", "sp", "current_target", "remaining", "visited", "photos", "photo_count",
                 "last_photo_target", "last_photo_time", "last_photo_x", "last_photo_y", "avoid_count", "detour",
                 "path", "path_goal", "plan_count", "brake_count", "braking", "brake_point", "command_taken")

    def __init__(self, setpoint: tuple, assigned: list[int]):
        self.state = PREFLIGHT
        self.cmd = 1
        self.sp = setpoint
        self.current_target = -1
        self.remaining = list(assigned)
        self.visited: list[int] = []
        self.photos: list[tuple[int, float, float, float]] = []
        self.photo_count = 0
        self.last_photo_target = -1
        self.last_photo_time = 0.0
        self.last_photo_x = 0.0
        self.last_photo_y = 0.0
        self.avoid_count = 0
        self.detour: list[tuple[float, float]] = []
        self.path: list[tuple[float, float]] = []
        self.path_goal = None
        self.plan_count = 0
        self.brake_count = 0
        self.braking = False
        self.brake_point = (0.0, 0.0)
        self.command_taken = COMMAND_NONE

    def __repr__(self):
        return "MissionState(" + ", ".join(f"{n}={getattr(self, n)!r}" for n in self.__slots__) + ")"


class _MissionField:
    """``strategy.<name>`` is ``strategy.mission.<name>``: the readers of a strategy's progress (the closed loop
    of uavsim/sim.py, the tests) keep their names while the state has one owner."""

    def __init__(self, name: str):
        self.name = name

    def __get__(self, strategy, owner=None):
        return self if strategy is None else getattr(strategy.mission, self.name)

    def __set__(self, strategy, value):
        setattr(strategy.mission, self.name, value)


class Strategy:
    """One UAV's mission: configuration fixed when built (parameters, targets, assignment, zones, margins) and
    its progress, ``mission`` (a :class:`MissionState`)."""

    def __init__(self, params: StrategyParams | None = None):
        self.p = params or StrategyParams()
        s = self.p.strategy.strip().upper()
        if s not in ("A", "B", "C"):       # C: uavsim/cooperative.py, B's step plus what it hears
            raise ValueError(f"strategy must be 'A', 'B' or 'C', got {self.p.strategy!r}")
        self.kind = s
        self.targets = as_points(self.p.targets)
        self.home = (float(self.p.home_x), float(self.p.home_y))
        self.assigned = assign_targets(self.targets, self.p.uav_index, self.p.uav_count,
                                       self.p.assignment, self.home)
        self.zones = ZoneMap(as_zones(self.p.zones), self.p.avoid_margin)
        self.planning = bool(self.p.zone_planning)
        # each UAV plans on its own "lane": clearance plan_margin + lane_spacing * uav_index, so
        # UAVs detouring around the same zone corner do not converge on one waypoint
        self.margin = float(self.p.plan_margin) + float(self.p.lane_spacing) * max(0, int(self.p.uav_index))
        self.mission = MissionState((self.home[0], self.home[1], float(self.p.cruise_altitude)), self.assigned)
        self.step_constants = self._pack_step_constants()

    def _pack_step_constants(self) -> bytes | None:
        """What the compiled step needs of the configuration, as native doubles (layout C_* of
        uavsim/_strategy_ext.c): arrival radius, land and return thresholds, look-ahead, brake deceleration (as
        _planned_waypoint bounds it), cruise altitude, base, planning flag, targets assigned, target count, zone
        count, the targets (x, y), then each zone's record (zone_record).  None (no compiled step) when a value
        is not a number."""
        p = self.p
        try:
            values = [p.arrival_radius, p.land_threshold, p.return_threshold, p.lookahead,
                      max(p.brake_accel, 1e-6), p.cruise_altitude, self.home[0], self.home[1],
                      1.0 if self.planning else 0.0, len(self.assigned), len(self.targets), len(self.zones.polys)]
            values += [v for point in self.targets for v in point]
            return array("d", [float(v) for v in values] + self.zones.records()).tobytes()
        except (AttributeError, TypeError, ValueError):
            return None

    # -------------------------------------------------------------- what the FMU publishes
    @property
    def avoiding(self) -> bool:
        m = self.mission
        if self.planning:
            return m.braking or len(m.path) > 1
        return bool(m.detour)

    @property
    def targets_assigned(self) -> int:
        return len(self.assigned)

    @property
    def targets_visited(self) -> int:
        return len(self.mission.visited)

    def outputs(self) -> tuple:
        """The FMU's outputs (OUTPUT_NAMES) in one call: cmd, setpoint x, y, z, state, targets assigned and
        visited, photo count, last photo target, current target, avoiding (0/1), avoid count, last photo time,
        x, y."""
        m = self.mission
        sp = m.sp
        if self.planning:
            avoiding = 1 if m.braking or len(m.path) > 1 else 0
        else:
            avoiding = 1 if m.detour else 0
        return (int(m.cmd), sp[0], sp[1], sp[2], int(m.state), len(self.assigned), len(m.visited),
                m.photo_count, m.last_photo_target, m.current_target, avoiding, m.avoid_count,
                m.last_photo_time, m.last_photo_x, m.last_photo_y)

    # -------------------------------------------------------------- legs
    def _goal(self):
        m = self.mission
        if m.state == TRANSIT and m.current_target >= 0:
            return self.targets[m.current_target]
        return self.home

    def _start_leg(self, x, y):
        m = self.mission
        m.detour = []
        if m.state == TRANSIT:
            m.current_target = next_target(self.kind, m.remaining, self.targets, x, y)
            if m.current_target < 0:
                m.state = RETURN_DONE

    def _waypoint(self, x, y, vx, vy):
        """Where to fly now, around the zones: the goal, or a waypoint of the way around."""
        goal = self._goal()
        if not self.zones:
            return goal
        if self.planning:
            return self._planned_waypoint(x, y, vx, vy, goal)
        return self._reactive_waypoint(x, y, vx, vy, goal)

    # ---- zone_planning true: plan each leg, safety net against drift
    def _replan(self, x, y, goal):
        m = self.mission
        m.path_goal = goal
        path = self.zones.plan((x, y), goal, self.margin)
        m.path = list(path) if path else [tuple(goal)]
        m.plan_count += 1
        if len(m.path) > 1:
            m.avoid_count += 1

    def _planned_waypoint(self, x, y, vx, vy, goal):
        m = self.mission
        if goal != m.path_goal:                 # a new leg: plan it
            m.braking = False
            self._replan(x, y, goal)
        groundspeed = math.hypot(vx, vy)
        if m.braking:
            if groundspeed > 0.5:
                return m.brake_point
            m.braking = False                   # stopped: go around from here
            self._replan(x, y, goal)
        path, r = m.path, self.p.arrival_radius
        while len(path) > 1 and math.hypot(path[0][0] - x, path[0][1] - y) <= r:
            path.pop(0)
        wx, wy = path[0]
        if groundspeed > 0.5:
            # last-resort safety net: where the UAV is going (along its velocity) within its
            # stopping distance plus the look-ahead, but not beyond the waypoint it stops at
            reach = min(self.p.lookahead + groundspeed * groundspeed / (2.0 * max(self.p.brake_accel, 1e-6)),
                        math.hypot(wx - x, wy - y))
            if reach > 1e-9 and self.zones.blocked(
                    (x, y), (x + reach * vx / groundspeed, y + reach * vy / groundspeed)) >= 0:
                m.braking = True
                m.brake_point = (float(x), float(y))
                m.brake_count += 1
                m.avoid_count += 1
                return m.brake_point
        if self.zones.blocked((x, y), (wx, wy)) >= 0:   # drifted: the way to the waypoint is blocked
            self._replan(x, y, goal)
        return m.path[0]

    # ---- zone_planning false: the paper's late detection
    def _reactive_waypoint(self, x, y, vx, vy, goal):
        m = self.mission
        r = self.p.arrival_radius
        # advance along a detour
        while m.detour and len(m.detour) > 1 and \
                math.hypot(m.detour[0][0] - x, m.detour[0][1] - y) <= r:
            m.detour.pop(0)
        if m.detour and len(m.detour) == 1:
            m.detour = []          # only the goal is left: normal flight
        if m.detour:
            wp = m.detour[0]
            if self.zones.blocked((x, y), wp) >= 0:
                self._plan_detour(x, y, goal)
            return m.detour[0] if m.detour else goal
        # look-ahead along the flight direction
        groundspeed = math.hypot(vx, vy)
        if groundspeed > 0.5:
            ux, uy = vx / groundspeed, vy / groundspeed
        else:
            dx, dy = goal[0] - x, goal[1] - y
            dd = math.hypot(dx, dy)
            if dd < 1e-9:
                return goal
            ux, uy = dx / dd, dy / dd
        la = self.p.lookahead
        if self.zones.blocked((x, y), (x + la * ux, y + la * uy)) >= 0 or \
                self.zones.blocked((x, y), self._towards(x, y, goal, la)) >= 0:
            self._plan_detour(x, y, goal)
        return m.detour[0] if m.detour else goal

    @staticmethod
    def _towards(x, y, goal, dist):
        """The point ``dist`` along the way to the goal, or the goal when it is nearer."""
        dx, dy = goal[0] - x, goal[1] - y
        dd = math.hypot(dx, dy)
        if dd <= dist or dd < 1e-9:
            return goal
        return (x + dist * dx / dd, y + dist * dy / dd)

    def _plan_detour(self, x, y, goal):
        m = self.mission
        path = self.zones.detour((x, y), goal)
        if path is None or len(path) <= 1:
            m.detour = []
        else:
            m.detour = list(path)
            m.avoid_count += 1

    # -------------------------------------------------------------- ground-station commands
    def command(self, code: int, x: float, y: float, z: float) -> bool:
        """A command from outside (see the module docstring); True when it changed the mission state."""
        m = self.mission
        if code == COMMAND_RETURN and m.state in (TRANSIT, RETURN_DONE):
            m.state, m.current_target, m.detour = RETURN_CMD, -1, []
            return True
        if code == COMMAND_LAND and m.state in (TRANSIT, RETURN_DONE, RETURN_LOW, RETURN_CMD):
            m.state, m.detour, m.cmd, m.sp = LAND_CMD, [], 3, (x, y, z)
            return True
        return False

    # -------------------------------------------------------------- the step
    def step(self, t: float, x: float, y: float, z: float, vx: float, vy: float,
             phase: int, consumed: float, command: int | None = None) -> None:
        """Evaluate the mission logic on the inputs sampled at time t and set the outputs.  ``command``, the FMU's
        ground-station input, is taken first when it differs from the last one taken.  With it, this is the FMU's
        step: the reference of the compiled step (uavsim/strategy_accel.py)."""
        if command is not None and command != self.mission.command_taken:
            self.mission.command_taken = command
            self.command(int(command), x, y, z)
        p = self.p
        m = self.mission
        phase = int(phase)
        airborne_states = (TRANSIT, RETURN_DONE, RETURN_LOW, RETURN_CMD)
        at_base = math.hypot(x - self.home[0], y - self.home[1]) <= p.arrival_radius

        # ---- terminal / landing states
        if m.state in (LAND_BASE, LAND_NOW, LAND_CMD):
            if phase == 4:
                m.state = LANDED_BASE if at_base else LANDED_AWAY
        if m.state in (LANDED_BASE, LANDED_AWAY):
            m.cmd = 3
            return
        if m.state in (LAND_BASE, LAND_NOW, LAND_CMD):
            m.cmd = 3
            return

        # ---- battery rules (only when airborne)
        if phase in (1, 2, 3):
            if consumed >= p.land_threshold:
                m.state = LAND_NOW if not at_base else LAND_BASE
                m.detour = []
                m.cmd = 3
                m.sp = (x, y, z)
                return
            if consumed >= p.return_threshold and m.state in (TAKEOFF, TRANSIT, RETURN_DONE):
                if m.state != RETURN_DONE:
                    m.state = RETURN_LOW
                    m.current_target = -1
                    m.detour = []

        # ---- takeoff
        if m.state == PREFLIGHT:
            m.cmd = 1
            if phase == 1:
                m.state = TAKEOFF
            elif phase == 2:
                m.state = TAKEOFF
            else:
                return
        if m.state == TAKEOFF:
            m.cmd = 1
            if phase != 2:
                return
            m.state = TRANSIT
            self._start_leg(x, y)
        if phase == 4 and m.state in airborne_states:
            # the vehicle landed on its own (should not happen): treat as final
            m.state = LANDED_BASE if at_base else LANDED_AWAY
            m.cmd = 3
            return

        # ---- target arrival and photos
        if m.state == TRANSIT:
            if m.current_target < 0:
                self._start_leg(x, y)
            tgt = m.current_target
            if tgt >= 0:
                tx, ty = self.targets[tgt]
                if math.hypot(tx - x, ty - y) <= p.arrival_radius:
                    m.photo_count += 1
                    m.last_photo_target = tgt
                    m.last_photo_time = float(t)
                    m.last_photo_x, m.last_photo_y = float(x), float(y)
                    m.photos.append((tgt, float(t), float(x), float(y)))
                    m.visited.append(tgt)
                    m.remaining.remove(tgt)
                    self._start_leg(x, y)

        # ---- return to base
        if m.state in (RETURN_DONE, RETURN_LOW, RETURN_CMD) and at_base:
            m.state = LAND_BASE
            m.detour = []
            m.cmd = 3
            m.sp = (x, y, z)
            return

        wx, wy = self._waypoint(x, y, vx, vy)
        m.cmd = 2
        m.sp = (float(wx), float(wy), float(p.cruise_altitude))


for _name in MissionState.__slots__:
    setattr(Strategy, _name, _MissionField(_name))
del _name
