"""UavStrategy (uavsim.strategy): assignment, Strategy A/B order, battery rules, zone fly-around."""
import math

import pytest
from shapely.geometry import Point, Polygon

from uavsim.dynamics import DynamicsParams
from uavsim.sim import simulate_mission
from uavsim.strategy import (LAND_BASE, LAND_NOW, LANDED_AWAY, LANDED_BASE, RETURN_DONE, RETURN_LOW,
                             TRANSIT, Strategy, StrategyParams, ZoneMap, assign_targets, parse_points)

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


@pytest.mark.parametrize("speed,lookahead,avoided", [
    (2.0, 2.0, True),     # braking distance v^2 / (2a) = 0.8 m < 2 m look-ahead: flies around
    (10.0, 25.0, True),   # 20 m braking distance < 25 m look-ahead: flies around
    (10.0, 2.0, False),   # the paper's 2 m look-ahead at 10 m/s (20 m to stop): enters the zone
])
def test_zone_fly_around_square(speed, lookahead, avoided):
    r = simulate_mission(StrategyParams(targets="100,0", zones=SQUARE_S, lookahead=lookahead),
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
