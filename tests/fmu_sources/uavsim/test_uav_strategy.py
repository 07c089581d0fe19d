"""UavStrategy (uavsim.strategy): assignment, Strategy A/B order, battery rules, zone planning and fly-around; the
FMU shell's state and outputs.  (The compiled step against the Python one: the accelerator harness, tests/accelerators/.)"""
import math

import pytest
from shapely.geometry import Point, Polygon

from uavsim.dynamics import DynamicsParams
from uavsim.sim import simulate_mission
from uavsim import params as PP
from uavsim.strategy import (LAND_BASE, LAND_NOW, LANDED_AWAY, LANDED_BASE, RETURN_DONE, RETURN_LOW,
                             TRANSIT, Strategy, StrategyParams, ZoneMap, ZonePlanner, assign_targets,
                             parse_points, parse_zones)

# hand-made layout (ENU m), base at (0, 0)
LAYOUT = "100,0;-10,0;50,0;0,30"


def test_assignment_rules():
    t = parse_points("0,1;0,2;0,3;0,4;0,5")
    # equal = contiguous blocks, first n mod N UAVs get one extra: [0,1,2] and [3,4]
    assert assign_targets(t, 0, 2, "equal") == [0, 1, 2]
    assert assign_targets(t, 1, 2, "equal") == [3, 4]
    # 24 targets over 1..4 UAVs: 24/N each, together all of them exactly once
    t24 = [(float(i), 0.0) for i in range(24)]
    for n in (1, 2, 3, 4):
        parts = [assign_targets(t24, i, n) for i in range(n)]
        assert all(len(p) == 24 // n for p in parts)
        assert sorted(sum(parts, [])) == list(range(24))
    # roundrobin: k mod N
    assert assign_targets(t, 1, 2, "roundrobin") == [1, 3]
    # spatial: bearings of LAYOUT about the base: #0 0, #1 pi, #2 0, #3 pi/2 -> sorted by
    # (bearing, distance): 2, 0, 3, 1 -> UAV0 {0, 2} (east), UAV1 {1, 3} (north, west)
    lay = parse_points(LAYOUT)
    assert assign_targets(lay, 0, 2, "spatial") == [0, 2]
    assert assign_targets(lay, 1, 2, "spatial") == [1, 3]
    # the sectors are about the base (ENU origin), not about the UAV's own pad: a pad passed as
    # ``home`` (the old signature) changes nothing
    assert assign_targets(lay, 0, 2, "spatial", (0.0, 8.0)) == [0, 2]
    assert assign_targets(lay, 1, 2, "spatial", (-3.0, -4.0)) == [1, 3]


def pads(n, spacing=8.0):
    """The landing pads of the scenario builder (uavstudy.build.pad_positions)."""
    if n <= 1:
        return [(0.0, 0.0)]
    r = spacing / (2.0 * math.sin(math.pi / n))
    return [(r * math.sin(2 * math.pi * i / n), r * math.cos(2 * math.pi * i / n)) for i in range(n)]


# the paper area's 24 targets (ssp/scenarios/paper_area.yaml, ENU m about the base)
PAPER_TARGETS = ("164.398,-276.305;-550.795,-580.196;375.904,495.305;127.999,275.398;52.304,522.105;"
                 "378.999,-596.697;428.895,-559.701;275.597,-389.196;435.802,49.802;-240.303,-92.795;"
                 "-566.004,-450.903;204.699,176.597;138.501,-139.601;596.696,577.004;226.100,-133.297;"
                 "-437.903,265.796;30.404,-227.695;-16.997,467.402;520.904,-170.594;113.199,-194.504;"
                 "-130.098,468.298;-327.396,147.796;-499.198,399.203;344.500,-312.804")
PAPER_ZONES = ("70.404,-147.896;156.701,-38.700;111.896,-3.197;25.600,-112.404|"
               "104.000,167.097;-2.695,174.297;-8.901,82.498;97.705,75.198|"
               "-75.197,-141.205;-104.596,-1.195;-194.096,-20.097;-164.697,-159.996|"
               "-343.598,211.602;-322.803,319.195;-387.797,331.703;-408.503,224.199")


@pytest.mark.parametrize("assignment", ["equal", "roundrobin", "spatial"])
@pytest.mark.parametrize("layout", ["paper", "ring"])
def test_every_target_assigned_exactly_once(assignment, layout):
    # each UAV's strategy instance computes its own list from its own parameters (its pad as home):
    # together the lists must be a partition of the targets, for 1..8 UAVs
    if layout == "paper":
        targets = parse_points(PAPER_TARGETS)
    else:   # targets on sector borders: equal bearings, ties broken by distance then index
        targets = [(r * math.cos(a), r * math.sin(a)) for a in (0.0, math.pi / 2, math.pi, 1.5 * math.pi)
                   for r in (30.0, 60.0, 90.0)]
    n = len(targets)
    for count in range(1, 9):
        lists = []
        for i, (hx, hy) in enumerate(pads(count)):
            s = Strategy(StrategyParams(uav_index=i, uav_count=count, assignment=assignment,
                                        targets=";".join(f"{x},{y}" for x, y in targets),
                                        home_x=hx, home_y=hy))
            lists.append(s.assigned)
        flat = sorted(k for lst in lists for k in lst)
        assert flat == list(range(n)), (assignment, count, lists)
        sizes = [len(lst) for lst in lists]
        assert max(sizes) - min(sizes) <= 1


def photo_order(strategy):
    r = simulate_mission(StrategyParams(strategy=strategy, targets=LAYOUT), step=0.1)
    s = r.strategy
    assert s.state == LANDED_BASE
    return [p[0] for p in s.photos], s


def test_strategy_a_defined_order():
    order, s = photo_order("A")
    assert order == [0, 1, 2, 3]
    assert s.photo_count == 4 and s.targets_visited == 4 and s.last_photo_target == 3
    # photos are taken within the 2 m arrival radius of the target
    tx, ty = parse_points(LAYOUT)[3]
    assert math.hypot(s.last_photo_x - tx, s.last_photo_y - ty) <= 2.0


def test_strategy_b_nearest_first():
    # from the base: distances 100, 10, 50, 30 -> #1 (-10, 0); from ~(-8, 0): #0 108, #2 58,
    # #3 31 -> #3 (0, 30); from ~(0, 28): #0 104, #2 57 -> #2; then #0
    order, _ = photo_order("B")
    assert order == [1, 3, 2, 0]


def drive(s, consumed, x=50.0, y=0.0, phase=2, t=0.0):
    s.step(t, x, y, 20.0, 0.0, 0.0, phase, consumed)
    return s


def test_return_at_80_and_land_at_95_percent():
    s = Strategy(StrategyParams(targets="500,0"))
    drive(s, 0.0, 0, 0, phase=0)
    drive(s, 0.0, 0, 0, phase=1)
    drive(s, 0.79)
    assert s.state == TRANSIT and s.cmd == 2 and s.sp[:2] == (500.0, 0.0)
    drive(s, 0.7999999)
    assert s.state == TRANSIT
    drive(s, 0.80)                                     # 80 % consumed: abandon, fly home
    assert s.state == RETURN_LOW and s.cmd == 2 and s.sp[:2] == (0.0, 0.0)
    drive(s, 0.9499)
    assert s.state == RETURN_LOW
    drive(s, 0.95, x=40.0)                             # 95 %: land where it is
    assert s.state == LAND_NOW and s.cmd == 3 and s.sp[:2] == (40.0, 0.0)
    drive(s, 0.96, x=40.0, phase=4)
    assert s.state == LANDED_AWAY and s.cmd == 3


def test_return_rule_in_closed_loop_fires_at_80_percent():
    # start with 22 % charge (consumed 0.78) and a far target: the UAV must turn home on the first
    # decision with consumed >= 0.8 and never photograph the target
    from uavsim.battery import Battery, BatteryParams
    b = Battery(params=BatteryParams(initial_soc=0.22))
    r = simulate_mission(StrategyParams(targets="2000,0"), battery=b, step=0.1, record_every=1)
    states, cons = r.state, r.consumed
    first = next(i for i, c in enumerate(cons) if c >= 0.8)
    assert all(st != RETURN_LOW for st in states[:first + 1])
    assert states[first + 1] == RETURN_LOW               # decided on the next sample
    assert r.strategy.photo_count == 0
    assert r.strategy.state == LANDED_BASE
    assert 0.8 < cons[-1] < 0.95


SQUARE = [(40, -10), (60, -10), (60, 10), (40, 10)]
SQUARE_S = "40,-10;60,-10;60,10;40,10"


def min_signed_distance(r):
    poly = Polygon(SQUARE)
    return min(-1.0 if poly.contains(Point(x, y)) else poly.exterior.distance(Point(x, y))
               for x, y in zip(r.x, r.y))


def min_signed_distance_polys(r, zones):
    polys = [Polygon(z) for z in parse_zones(zones)]
    return min(min(-p.exterior.distance(Point(x, y)) if p.contains(Point(x, y)) else p.exterior.distance(Point(x, y))
                   for p in polys) for x, y in zip(r.x, r.y))


@pytest.mark.parametrize("speed,lookahead,avoided", [
    (2.0, 2.0, True),     # braking distance v^2 / (2a) = 0.8 m < 2 m look-ahead: flies around
    (10.0, 25.0, True),   # 20 m braking distance < 25 m look-ahead: flies around
    (10.0, 2.0, False),   # the paper's 2 m look-ahead at 10 m/s (20 m to stop): enters the zone
])
def test_zone_fly_around_square_paper_late_detection(speed, lookahead, avoided):
    # zone_planning false: the paper's reactive behaviour, collision-prone at cruise speed
    r = simulate_mission(StrategyParams(targets="100,0", zones=SQUARE_S, lookahead=lookahead, zone_planning=False),
                         dynamics=DynamicsParams(speed=speed), step=0.1, record_every=1, t_end=900)
    s = r.strategy
    assert s.avoid_count >= 1
    assert s.photo_count == 1 and s.state == LANDED_BASE
    if avoided:
        assert min_signed_distance(r) > 0.0
    else:
        assert min_signed_distance(r) < 0.0


def test_detour_takes_shorter_side():
    # zone spans y in [-5, 30]: around the south side (y = -5 - 3 m margin) is shorter
    zm = ZoneMap([[(40, -5), (60, -5), (60, 30), (40, 30)]], margin=3.0)
    path = zm.detour((30.0, 0.0), (100.0, 0.0))
    assert path[-1] == (100.0, 0.0)
    assert [p[1] for p in path[:-1]] == [pytest.approx(-8.0)] * (len(path) - 1)
    # length: (30,0)->(37,-8)->(63,-8)->(100,0) = 10.63 + 26 + 37.85
    pts = [(30.0, 0.0)] + path
    length = sum(math.dist(a, b) for a, b in zip(pts, pts[1:]))
    assert length == pytest.approx(math.hypot(7, 8) + 26 + math.hypot(37, 8), rel=1e-9)


def test_all_visited_returns_and_lands_at_base():
    r = simulate_mission(StrategyParams(targets="30,0", home_x=5.0, home_y=5.0), step=0.2)
    s = r.strategy
    assert s.state == LANDED_BASE and s.photo_count == 1
    assert math.hypot(r.dynamics.pos[0] - 5.0, r.dynamics.pos[1] - 5.0) <= 2.0
    assert RETURN_DONE in r.state and LAND_BASE in r.state


# ---------------------------------------------------------------------- zone planning (default)
def test_plan_margin_is_braking_distance_at_cruise():
    assert PP.PLAN_MARGIN == pytest.approx(PP.WP_SPEED ** 2 / (2 * PP.WP_ACCEL)) == pytest.approx(20.0)
    assert StrategyParams().zone_planning is True and StrategyParams().plan_margin == PP.PLAN_MARGIN


def test_planner_keeps_margin_and_takes_shorter_side():
    zp = ZonePlanner([Polygon([(40, -5), (60, -5), (60, 30), (40, 30)])], 20.0)
    path = zp.plan((0.0, 0.0), (100.0, 0.0))
    assert path[-1] == (100.0, 0.0)
    # around the south side: (20, -25) -> (80, -25) are the mitred offset corners
    assert path[:-1] == [pytest.approx((20.0, -25.0)), pytest.approx((80.0, -25.0))]
    pts = [(0.0, 0.0)] + path
    from shapely.geometry import LineString
    for a, b in zip(pts, pts[1:]):
        assert zp.union.distance(LineString([a, b])) >= 20.0 * 0.99
    # a free leg is flown straight
    assert zp.plan((0.0, 0.0), (0.0, 100.0)) == [(0.0, 100.0)]
    # inside a zone: no path
    assert zp.plan((50.0, 0.0), (100.0, 0.0)) is None


def test_planner_target_within_margin_reduced_clearance():
    # target 3 m east of the square: the approach keeps >= 0.9 x 3 m, the rest the full margin
    zp = ZonePlanner([Polygon(SQUARE)], 20.0)
    path = zp.plan((0.0, 0.0), (63.0, 0.0))
    assert path is not None and path[-1] == (63.0, 0.0)
    from shapely.geometry import LineString
    pts = [(0.0, 0.0)] + path
    clear = [zp.union.distance(LineString([a, b])) for a, b in zip(pts, pts[1:])]
    assert min(clear[:-1]) >= 19.8 and clear[-1] >= 0.9 * 3.0 * 0.99


def test_planned_square_is_avoided_at_cruise_speed_with_paper_lookahead():
    # the case the paper's late detection fails (10 m/s, 2 m look-ahead): planned around, with margin
    r = simulate_mission(StrategyParams(targets="100,0", zones=SQUARE_S, lookahead=2.0),
                         step=0.1, record_every=1, t_end=900)
    s = r.strategy
    assert s.photo_count == 1 and s.state == LANDED_BASE
    assert s.avoid_count >= 2 and s.brake_count == 0        # out and back detoured, no emergency
    assert min_signed_distance(r) > 15.0


NEAR_CASES = {
    # name: (targets, zones, minimum clearance expected of the flown track)
    "edge_3m": ("63,0", SQUARE_S, 2.0),
    "corner": ("62,12", SQUARE_S, 1.5),
    "behind": ("70,0;-20,5", SQUARE_S, 8.0),
    "gap_10m": ("50,0", "40,-50;60,-50;60,-5;40,-5|40,5;60,5;60,50;40,50", 4.0),
    "pocket": ("60,0", "40,-30;100,-30;100,-20;50,-20;50,20;100,20;100,30;40,30", 8.0),
}


@pytest.mark.parametrize("step", [0.1, 1.0])
@pytest.mark.parametrize("case", sorted(NEAR_CASES))
def test_targets_close_to_zones_reached_without_deadlock(case, step):
    targets, zones, clearance = NEAR_CASES[case]
    r = simulate_mission(StrategyParams(strategy="A", targets=targets, zones=zones), step=step,
                         record_every=1, t_end=600)
    s = r.strategy
    assert s.state == LANDED_BASE and s.photo_count == len(parse_points(targets))
    assert min_signed_distance_polys(r, zones) >= clearance
    assert r.t[-1] < 200.0                 # no stalling: each leg is a few hundred metres at most


def drive_xy(s, t, x, y, vx, vy, consumed=0.1):
    s.step(t, x, y, 20.0, vx, vy, 2, consumed)
    return s.sp[:2]


def test_safety_net_brakes_then_goes_around():
    s = Strategy(StrategyParams(targets="100,0", zones=SQUARE_S))
    s.step(0.0, 0, 0, 0, 0, 0, 0, 0.0)
    s.step(1.0, 0, 0, 10, 0, 0, 1, 0.0)
    wp = drive_xy(s, 2.0, 0.0, 0.0, 0.0, 0.0)               # leg planned around the square
    assert s.avoiding and s.plan_count == 1 and wp != (100.0, 0.0)
    # a drift puts the UAV on course into the zone at 10 m/s (stopping distance 20 m + 2 m)
    sp = drive_xy(s, 3.0, 20.0, 0.0, 10.0, 0.0)
    assert s.braking and s.brake_count == 1 and sp == (20.0, 0.0)
    sp = drive_xy(s, 4.0, 32.0, 0.0, 4.0, 0.0)              # still braking: hold the brake point
    assert s.braking and sp == (20.0, 0.0)
    sp = drive_xy(s, 5.0, 35.0, 0.0, 0.2, 0.0)              # stopped 5 m before the zone: re-plan
    assert not s.braking and s.plan_count == 2 and s.avoiding
    assert s.path[-1] == (100.0, 0.0)
    from shapely.geometry import LineString
    pts = [(35.0, 0.0)] + s.path
    zp = ZonePlanner([Polygon(SQUARE)], 20.0)
    assert all(zp.union.distance(LineString([a, b])) > 4.0 for a, b in zip(pts, pts[1:]))


def test_return_and_landing_legs_are_planned():
    # the target lies behind the zone: the return leg home must be planned around it as well
    r = simulate_mission(StrategyParams(targets="100,0", zones=SQUARE_S, home_x=5.0, home_y=1.0),
                         step=0.5, record_every=1, t_end=900)
    s = r.strategy
    assert s.state == LANDED_BASE and s.plan_count == 2        # out, home
    assert math.hypot(r.dynamics.pos[0] - 5.0, r.dynamics.pos[1] - 1.0) <= 2.0
    assert min_signed_distance(r) > 15.0


@pytest.mark.parametrize("strategy", ["A", "B"])
def test_paper_zones_four_uavs_fly_their_missions(strategy):
    # the shipped headline scenario (paper_area_zones.yaml, 4 UAVs on their pads), no wind: every
    # UAV visits its 6 targets, returns to its pad and keeps the planning margin from every zone
    for i, (hx, hy) in enumerate(pads(4)):
        r = simulate_mission(StrategyParams(strategy=strategy, uav_index=i, uav_count=4, targets=PAPER_TARGETS,
                                            zones=PAPER_ZONES, home_x=hx, home_y=hy), step=1.0, t_end=1500)
        s = r.strategy
        assert s.state == LANDED_BASE and len(s.visited) == 6 and s.brake_count == 0
        assert min_signed_distance_polys(r, PAPER_ZONES) > 15.0
        assert r.consumed[-1] < 0.6


def test_paper_zones_late_detection_enters_zones():
    # zone_planning false reproduces the paper's collision-prone behaviour on the same scenario
    hits = 0
    for i, (hx, hy) in enumerate(pads(4)):
        r = simulate_mission(StrategyParams(strategy="B", uav_index=i, uav_count=4, targets=PAPER_TARGETS,
                                            zones=PAPER_ZONES, home_x=hx, home_y=hy, zone_planning=False),
                             step=1.0, t_end=1500)
        hits += min_signed_distance_polys(r, PAPER_ZONES) < 0.0
    assert hits == 4


def test_lanes_separate_the_detours_of_different_uavs():
    # UAV i plans with plan_margin + i * lane_spacing: two UAVs sent round the same corner get
    # waypoints >= lane_spacing apart (instead of one shared visibility-graph vertex)
    paths = []
    for i in range(4):
        s = Strategy(StrategyParams(targets="100,0", zones=SQUARE_S, uav_index=i, uav_count=4))
        assert s.margin == pytest.approx(PP.PLAN_MARGIN + i * PP.LANE_SPACING)
        s.step(0.0, 0, 0, 0, 0, 0, 0, 0.0)
        s.step(1.0, 0, 0, 10, 0, 0, 1, 0.0)
        s.step(2.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.0)
        paths.append(list(s.path))
    for a in range(4):
        for b in range(a + 1, 4):
            for p, q in zip(paths[a][:-1], paths[b][:-1]):
                assert math.dist(p, q) >= PP.LANE_SPACING * 0.99


def test_blocked_is_shapely_on_every_zone():
    # ZoneMap.blocked skips zones by bounding squares and circles; its answer must be shapely's own test against
    # every zone (first zone hit, -1 for none), for segments near, across, inside and far from the zones
    import random

    from shapely.geometry import LineString, Point

    from uavsim.strategy import ZoneMap
    rng = random.Random(11)
    zones = [[(100, 100), (160, 100), (160, 150), (100, 150)], [(-80, 20), (-40, 90), (-120, 60)],
             [(0, -200), (30, -260), (-30, -260)]]
    zm = ZoneMap(zones)
    hits = 0
    for _ in range(4000):
        ax, ay = rng.uniform(-250, 250), rng.uniform(-300, 250)
        if rng.random() < 0.3:
            bx, by = ax, ay
        else:
            ln = rng.choice([2.0, 25.0, 300.0])
            ang = rng.uniform(0, 6.3)
            bx, by = ax + ln * math.cos(ang), ay + ln * math.sin(ang)
        geom = Point(ax, ay) if math.hypot(bx - ax, by - ay) < 1e-9 else LineString([(ax, ay), (bx, by)])
        expected = next((i for i, pz in enumerate(zm._prep) if pz.intersects(geom)), -1)
        assert zm.blocked((ax, ay), (bx, by)) == expected
        hits += expected >= 0
    assert 50 < hits < 3950
    # a non-finite end point takes no shortcut: shapely decides, whatever it makes of it
    import warnings
    with warnings.catch_warnings():          # shapely warns of the invalid coordinates, as it always did
        warnings.simplefilter("ignore", RuntimeWarning)
        for a, b in (((math.nan, 120.0), (130.0, 120.0)), ((math.inf, 0.0), (0.0, 0.0)),
                     ((5.0, 5.0), (6.0, math.nan))):
            line = LineString([a, b])
            assert zm.blocked(a, b) == next((i for i, pz in enumerate(zm._prep) if pz.intersects(line)), -1)


@pytest.mark.parametrize("planning", [True, False])
def test_outputs_are_the_published_attributes(planning, monkeypatch):
    # Strategy.outputs() (one call per FMU step) gives exactly what the FMU used to read attribute by attribute,
    # at every step of a mission with a zone detour, photos and the return
    from uavsim.strategy import Strategy
    seen = []
    step = Strategy.step

    def checked(self, *a):
        step(self, *a)
        o = self.outputs()
        assert o == (int(self.cmd), *self.sp, int(self.state), self.targets_assigned, self.targets_visited,
                     self.photo_count, self.last_photo_target, self.current_target, int(self.avoiding),
                     self.avoid_count, self.last_photo_time, self.last_photo_x, self.last_photo_y)
        seen.append(o[10])
    monkeypatch.setattr(Strategy, "step", checked)
    res = simulate_mission(StrategyParams(strategy="B", targets="150,10;-60,200", zone_planning=planning,
                                          zones="40,-20;80,-20;80,60;40,60"), t_end=400.0)
    assert res.strategy.state == LANDED_BASE and res.strategy.targets_visited == 2
    assert 1 in seen and 0 in seen          # a detour was flown


# ---------------------------------------------------------------------- the FMU shell (fmu_sources/UavStrategy.py)
SHELL_OUTPUTS = ("cmd", "sp_x", "sp_y", "sp_z", "mission_state", "targets_assigned", "targets_visited",
                 "photo_count", "last_photo_target", "current_target", "avoiding", "avoid_count", "last_photo_time",
                 "last_photo_x", "last_photo_y")


def _shell_module():
    import importlib.util

    from build_script import SRC
    spec = importlib.util.spec_from_file_location("strategy_shell", SRC / "UavStrategy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _fly(shell, steps, t0, inputs=None):
    """Steps of the shell with a vehicle flying to its setpoint at 10 m/s (or the given inputs): the inputs and
    the outputs (floats by their bits) of each step."""
    from bitwise import bits
    seen, outs = [], []
    for k in range(steps):
        if inputs is None:
            dx, dy = shell.sp_x - shell.x, shell.sp_y - shell.y
            d = math.hypot(dx, dy)
            v = min(10.0, d / 0.1)
            vx, vy = (v * dx / d, v * dy / d) if d > 0 else (0.0, 0.0)
            step = dict(x=shell.x + 0.1 * vx, y=shell.y + 0.1 * vy, vx=vx, vy=vy, z=20.0,
                        phase=2 if shell.cmd == 2 or k > 0 else 1, consumed=0.001 * (t0 + k) * 0.1)
        else:
            step = inputs[k]
        for name, value in step.items():
            setattr(shell, name, value)
        shell.do_step(0.1 * (t0 + k), 0.1)
        seen.append(step)
        outs.append(bits([getattr(shell, n) for n in SHELL_OUTPUTS]))
    return seen, outs


def test_shell_outputs_are_the_strategys_and_plain_attributes():
    # the compiled step writes the outputs as the shell's variables by name: valid only without properties or
    # __setattr__ on the class; the names are the strategy's OUTPUT_NAMES, in its order
    from uavsim.strategy import OUTPUT_NAMES
    cls = _shell_module().UavStrategy
    assert cls.__setattr__ is object.__setattr__
    assert not any(hasattr(cls, name) for name in SHELL_OUTPUTS)
    assert OUTPUT_NAMES == SHELL_OUTPUTS


def test_fmu_state_round_trip_flies_on_the_same():
    # FMI get/set state between steps (whichever step runs, compiled or not): a restored strategy flies on bit
    # for bit the same, ground-station command included
    shell = _shell_module().UavStrategy(instance_name="t", resources=".", visible=False)
    shell.targets, shell.n_targets, shell.n_zones, shell.strategy = "200,100;-200,300;100,-400", -1, -1, "B"
    shell.exit_initialization_mode()
    _fly(shell, 300, 0)
    state = shell._get_fmu_state()
    inputs, first = _fly(shell, 600, 300)
    assert shell.photo_count > 0
    shell._set_fmu_state(state)
    assert _fly(shell, 600, 300, inputs)[1] == first
    shell._set_fmu_state(state)
    inputs[0]["command"] = 1            # return to base: taken once, the mission differs from then on
    again = _fly(shell, 600, 300, inputs)[1]
    assert again != first and shell.mission_state in (LAND_BASE, LANDED_BASE, 9)


def test_a_shipped_mission_is_the_same_with_and_without_the_compiled_steps(tmp_path, capsys, monkeypatch):
    # a whole mission (zone detours included) run with the FMUs' compiled steps (in this process, where they are
    # loaded) and with COSIM_MASTER_PURE_PYTHON=1 (in a process of its own, so that nothing compiled can be left
    # loaded: forked by the tests' program server, which has loaded none of the project's compiled code, only
    # NumPy's, fmpy's and matplotlib's, checked in its /proc/PID/maps)
    import importlib.util
    import os
    import sys

    import program_server

    from build_script import SRC
    from cli_in_process import run_cli
    root = SRC.parent
    ssp = root / "ssp" / "paper_zones_1uav_B.ssp"
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "")
    fast = run_cli(["run", ssp, "-o", tmp_path / "fast"], cwd=root)
    assert fast.returncode == 0, fast.stderr
    env = dict(os.environ, COSIM_MASTER_PURE_PYTHON="1")
    program_server.run([sys.executable, "-m", "master.cli", "run", str(ssp), "-o", str(tmp_path / "pure")],
                       check=True, env=env, cwd=root, capture_output=True, text=True)
    spec = importlib.util.spec_from_file_location("compare_runs", root / "bench" / "compare_runs.py")
    compare_runs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compare_runs)
    code = compare_runs.main([str(tmp_path / "pure"), str(tmp_path / "fast")])
    assert code == 0, capsys.readouterr().out
