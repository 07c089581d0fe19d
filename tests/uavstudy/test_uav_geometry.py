"""Tests of uavstudy.geometry with hand-derived expectations."""
import math

import numpy as np
import pytest

from uavstudy.geometry import CollisionDetector, ZoneDetector


def P(*rows):
    return np.array(rows, dtype=float)


# ----------------------------------------------------------------- collisions
def test_head_on_between_samples():
    # A: x 0 -> 10, B: x 10 -> 0 over 1 s (10 m/s each); sampled 10 m apart at
    # both ends. Separation s(t) = 10 - 20 t = 2.6  =>  t = 0.37 s.
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [10, 0, 10])
    p1 = P([10, 0, 10], [0, 0, 10])
    (c,) = det.check(0.0, 1.0, p0, p1, np.array([True, True]))
    assert (c.i, c.j) == (0, 1)
    assert c.time == pytest.approx(0.37, abs=1e-12)
    assert c.pos_i == pytest.approx((3.7, 0, 10))
    assert c.pos_j == pytest.approx((6.3, 0, 10))
    assert c.min_distance == pytest.approx(0.0, abs=1e-12)
    assert c.time_min == pytest.approx(0.5)


def test_perpendicular_crossing_between_samples():
    # A: (-5,0) -> (5,0), B: (0,-5) -> (0,5), step [3, 4] s, 10 m/s each.
    # d(tau) = sqrt(2) |10 tau - 5| = 2.6 => tau = 0.5 - 0.26/sqrt(2)
    det = CollisionDetector()
    p0 = P([-5, 0, 20], [0, -5, 20])
    p1 = P([5, 0, 20], [0, 5, 20])
    contacts = det.check(3.0, 4.0, p0, p1, np.ones(2, bool))
    assert len(contacts) == 1
    c = contacts[0]
    tau = 0.5 - 0.26 / math.sqrt(2.0)      # 0.316152...
    assert c.time == pytest.approx(3.0 + tau, abs=1e-12)
    assert c.pos_i == pytest.approx((-5 + 10 * tau, 0, 20))
    assert c.pos_j == pytest.approx((0, -5 + 10 * tau, 20))
    assert math.dist(c.pos_i, c.pos_j) == pytest.approx(2.6)
    # the endpoints are sqrt(50) = 7.07 m apart: a sampled check misses it
    assert np.linalg.norm(p1[0] - p1[1]) > 7.0


def test_parallel_3m_apart_not_flagged():
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [0, 3, 10])
    p1 = P([10, 0, 10], [10, 3, 10])
    assert det.check(0, 1, p0, p1, np.ones(2, bool)) == []


def test_exact_boundary_parallel_2_6m_is_contact():
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [0, 2.6, 10])
    p1 = P([10, 0, 10], [10, 2.6, 10])
    (c,) = det.check(5, 6, p0, p1, np.ones(2, bool))
    assert c.time == 5.0                    # in contact from the start
    assert c.min_distance == pytest.approx(2.6)
    # just beyond the diameter: no contact
    p0[1, 1] = p1[1, 1] = 2.6 + 1e-6
    assert det.check(5, 6, p0, p1, np.ones(2, bool)) == []


def test_exact_boundary_touch_at_closest_approach():
    # opposite lanes 2.6 m apart: closest approach exactly 2.6 m at tau = 0.5
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [10, 2.6, 10])
    p1 = P([10, 0, 10], [0, 2.6, 10])
    (c,) = det.check(0, 2, p0, p1, np.ones(2, bool))
    assert c.time == pytest.approx(1.0, abs=1e-6)
    assert c.min_distance == pytest.approx(2.6)
    p0[1, 1] = p1[1, 1] = 2.61
    assert det.check(0, 2, p0, p1, np.ones(2, bool)) == []


def test_vertical_separation_counts_3d():
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [0, 0, 13])
    assert det.check(0, 1, p0, p0, np.ones(2, bool)) == []
    p1 = P([0, 0, 10], [0, 0, 12])          # descends 1 m: reaches 2.6 at tau = 0.4
    (c,) = det.check(0, 1, p0, p1, np.ones(2, bool))
    assert c.time == pytest.approx(0.4)


def test_inactive_vehicles_ignored():
    det = CollisionDetector(2.6)
    p0 = P([0, 0, 10], [10, 0, 10], [5, -5, 10])
    p1 = P([10, 0, 10], [0, 0, 10], [5, 5, 10])
    all_ = det.check(0, 1, p0, p1, np.ones(3, bool))
    assert {(c.i, c.j) for c in all_} == {(0, 1), (0, 2), (1, 2)}
    some = det.check(0, 1, p0, p1, np.array([True, False, True]))
    assert [(c.i, c.j) for c in some] == [(0, 2)]
    assert det.check(0, 1, p0, p1, np.array([False, False, True])) == []


def test_sorted_by_time_then_indices():
    det = CollisionDetector(2.6)
    # pair (2,3) meets early, pair (0,1) later
    p0 = P([0, 0, 0], [10, 0, 0], [100, 0, 0], [103, 0, 0])
    p1 = P([10, 0, 0], [0, 0, 0], [103, 0, 0], [100, 0, 0])
    cs = det.check(0, 1, p0, p1, np.ones(4, bool))
    assert [(c.i, c.j) for c in cs] == [(2, 3), (0, 1)]
    assert cs[0].time < cs[1].time


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
@pytest.mark.parametrize("cell_size", [None, 1.0, 50.0])
def test_broad_phase_equals_bruteforce(seed, cell_size):
    rng = np.random.default_rng(seed)
    n = 200
    p0 = rng.uniform(0, 150, (n, 3)) * [1, 1, 0.05]
    v = rng.normal(0, 8, (n, 3)) * [1, 1, 0.1]
    p1 = p0 + v
    # a few outliers with long displacements
    p1[:3] += rng.uniform(-300, 300, (3, 3))
    active = rng.random(n) > 0.1
    det = CollisionDetector(2.6, cell_size=cell_size, small_n=0)
    fast = det.check(10, 11, p0, p1, active)
    slow = det.check_bruteforce(10, 11, p0, p1, active)
    assert len(slow) > 5
    assert fast == slow


@pytest.mark.parametrize("n", [2, 5, 12, 13, 40])
def test_small_fleets_hash_and_allpairs_agree(n):
    rng = np.random.default_rng(n)
    p0 = rng.uniform(0, 20, (n, 3))
    p1 = p0 + rng.normal(0, 5, (n, 3))
    act = np.ones(n, bool)
    ref = CollisionDetector(small_n=0).check_bruteforce(0, 1, p0, p1, act)
    assert CollisionDetector(small_n=0).check(0, 1, p0, p1, act) == ref
    assert CollisionDetector(small_n=100).check(0, 1, p0, p1, act) == ref
    assert CollisionDetector().check(0, 1, p0, p1, act) == ref


def test_broad_phase_not_quadratic():
    rng = np.random.default_rng(5)
    n = 1024
    p0 = np.zeros((n, 3))
    p0[:, :2] = rng.uniform(0, 3000, (n, 2))
    p1 = p0 + rng.normal(0, 7, (n, 3)) * [1, 1, 0]
    det = CollisionDetector()
    det.check(0, 1, p0, p1, np.ones(n, bool))
    assert det.last_candidate_count < 5 * n        # vs n(n-1)/2 = 523776


def test_input_validation():
    det = CollisionDetector()
    with pytest.raises(ValueError):
        det.check(0, 1, np.zeros((3, 2)), np.zeros((3, 2)), np.ones(3, bool))
    with pytest.raises(ValueError):
        det.check(0, 1, np.zeros((3, 3)), np.zeros((3, 3)), np.ones(2, bool))
    assert det.check(0, 1, np.zeros((1, 3)), np.zeros((1, 3)), np.ones(1, bool)) == []
    assert det.check(0, 1, np.zeros((0, 3)), np.zeros((0, 3)), np.ones(0, bool)) == []


# ---------------------------------------------------------------------- zones
SQUARE = [(0, 0), (10, 0), (10, 10), (0, 10)]


def test_corner_cut_between_samples():
    # segment (-1,8) -> (3,12) lies on y = x + 9: enters the square through
    # its left edge at (0, 9) (fraction 1/4), leaves through the top at (1,10)
    det = ZoneDetector([SQUARE], ["sq"])
    p0 = P([-1, 8, 30])
    p1 = P([3, 12, 30])
    (z,) = det.check(2.0, 3.0, p0, p1, np.ones(1, bool))
    assert (z.vehicle, z.zone, z.zone_name) == (0, 0, "sq")
    assert z.fraction == pytest.approx(0.25)
    assert z.time == pytest.approx(2.25)
    assert z.position == pytest.approx((0, 9, 30))
    assert z.inside_at_end is False


def test_corner_cut_symmetric_fraction_half():
    det = ZoneDetector([SQUARE], ["sq"])
    (z,) = det.check(0, 1, P([-3, 6, 0]), P([3, 12, 0]), np.ones(1, bool))
    assert z.fraction == pytest.approx(0.5)
    assert z.position == pytest.approx((0, 9, 0))


def test_passing_beside_no_incursion():
    det = ZoneDetector([SQUARE], ["sq"])
    # y = x + 11 passes the corner (0,10) at 0.707 m: no impact radius for zones
    assert det.check(0, 1, P([-3, 8, 0]), P([3, 14, 0]), np.ones(1, bool)) == []
    # alongside the right edge, 0.5 m away
    assert det.check(0, 1, P([10.5, -5, 0]), P([10.5, 15, 0]), np.ones(1, bool)) == []


def test_start_inside_and_end_inside():
    det = ZoneDetector([SQUARE, [(20, 0), (30, 0), (30, 10)]], ["sq", "tri"])
    p0 = P([5, 5, 10], [15, 5, 10], [25, 1, 0])
    p1 = P([6, 5, 10], [25, 5, 10], [25, 1, 0])   # third one hovers inside tri
    zs = det.check(0, 1, p0, p1, np.ones(3, bool))
    by = {(z.vehicle, z.zone_name): z for z in zs}
    assert set(by) == {(0, "sq"), (1, "tri"), (2, "tri")}
    assert by[0, "sq"].fraction == 0.0 and by[0, "sq"].time == 0.0
    # vehicle 1: y = 5 meets the hypotenuse y = x - 20 at x = 25 -> fraction 1
    assert by[1, "tri"].fraction == pytest.approx(1.0)
    assert by[1, "tri"].inside_at_end
    assert by[2, "tri"].fraction == 0.0
    assert [z.time for z in zs] == sorted(z.time for z in zs)


def test_zone_infinite_height_and_inactive():
    det = ZoneDetector([SQUARE], ["sq"])
    p0 = P([-5, 5, 500], [-5, 5, 0])
    p1 = P([5, 5, 500], [5, 5, 0])
    zs = det.check(0, 1, p0, p1, np.array([True, False]))
    assert [(z.vehicle, z.fraction) for z in zs] == [(0, pytest.approx(0.5))]


def test_zone_boundary_counts_and_no_zones():
    det = ZoneDetector([SQUARE])
    (z,) = det.check(0, 1, P([-5, 5, 0]), P([0, 5, 0]), np.ones(1, bool))
    assert z.fraction == pytest.approx(1.0) and z.zone_name == "zone0"
    assert ZoneDetector([]).check(0, 1, P([0, 0, 0]), P([1, 1, 0]), np.ones(1, bool)) == []
    with pytest.raises(ValueError):
        ZoneDetector([[(0, 0), (1, 1)]])


# ------------------------------------------------------------ fast paths = reference paths
def _astuples(cs):
    import dataclasses
    return [dataclasses.astuple(c) for c in cs]


@pytest.mark.parametrize("n", [2, 3, 5, 8, 16, 17, 64, 300])
def test_python_sweep_hash_paths_agree_bit_for_bit(n):
    # dense enough for contacts; every broad phase must hand the same pairs to the same narrow phase
    rng = np.random.default_rng(100 + n)
    side = 6.0 * math.sqrt(n)
    p0 = np.column_stack((rng.uniform(0, side, (n, 2)), rng.uniform(9, 11, n)))
    p1 = p0 + rng.normal(0, 3, (n, 3)) * [1, 1, 0.1]
    active = rng.random(n) > 0.15
    active[:2] = True
    ref = _astuples(CollisionDetector(small_n=0, sweep=False).check(0.0, 1.0, p0, p1, active))
    assert ref == _astuples(CollisionDetector().check_bruteforce(0.0, 1.0, p0, p1, active))
    for det in (CollisionDetector(), CollisionDetector(small_n=0), CollisionDetector(py_n=0),
                CollisionDetector(small_n=1000, py_n=1000), CollisionDetector(sweep=False)):
        assert _astuples(det.check(0.0, 1.0, p0, p1, active)) == ref
    if n <= 64:
        idx = np.flatnonzero(active).tolist()
        few = CollisionDetector().check_few(0.0, 1.0, p0, p1, idx, p0.tolist(), p1.tolist())
        assert _astuples(few) == ref
    if n >= 16:
        assert ref, "test data should contain contacts"


def test_sweep_falls_back_to_hash_for_a_column_of_vehicles():
    # all on one north-south line: every x interval overlaps, the sweep gives up, the hash answers
    n = 200
    p0 = np.column_stack((np.zeros(n), np.arange(n) * 2.0, np.full(n, 10.0)))
    p1 = p0 + [0.5, 0.0, 0.0]
    det = CollisionDetector()
    got = det.check(0, 1, p0, p1, np.ones(n, bool))
    assert _astuples(got) == _astuples(det.check_bruteforce(0, 1, p0, p1, np.ones(n, bool)))
    assert len(got) == n - 1 and det.last_candidate_count < 5 * n


def test_nan_positions_never_collide_in_any_path():
    p0 = P([0, 0, 10], [1, 0, 10], [math.nan, 0, 10], [0.5, 0.5, 10])
    p1 = p0.copy()
    act = np.ones(4, bool)
    ref = _astuples(CollisionDetector().check_bruteforce(0, 1, p0, p1, act))
    assert {(c[0], c[1]) for c in ref} == {(0, 1), (0, 3), (1, 3)}
    assert _astuples(CollisionDetector().check(0, 1, p0, p1, act)) == ref
    assert _astuples(CollisionDetector().check_few(0, 1, p0, p1, [0, 1, 2, 3], p0.tolist(), p1.tolist())) == ref


def test_zone_bounding_box_reject_is_exact():
    zones = [SQUARE, [(40, 0), (60, 0), (50, 20)]]
    det = ZoneDetector(zones, ["sq", "tri"])
    rng = np.random.default_rng(3)
    n = 400
    p0 = np.column_stack((rng.uniform(-20, 80, (n, 2)), np.full(n, 5.0)))
    p1 = p0 + np.column_stack((rng.normal(0, 8, (n, 2)), np.zeros(n)))
    p1[:20] = p0[:20]                                           # hovering ones: point tests
    act = np.ones(n, bool)
    got = det.check(0, 1, p0, p1, act)
    # reference: every vehicle through shapely, one at a time, no reject
    import shapely
    ref = set()
    for k in range(n):
        g = (shapely.Point(p0[k, :2]) if (p0[k, :2] == p1[k, :2]).all()
             else shapely.LineString([p0[k, :2], p1[k, :2]]))
        for z, poly in enumerate(det.polygons):
            if g.intersects(poly):
                ref.add((k, z))
    assert {(z.vehicle, z.zone) for z in got} == ref and len(ref) > 10
    for k in range(n):
        may = det.may_enter(*p0[k, :2], *p1[k, :2])
        assert may or all(kz[0] != k for kz in ref)
    # the bounding box overlaps but the segment misses: shapely decides
    assert det.may_enter(-3, 8, 3, 14) and det.check(0, 1, P([-3, 8, 0]), P([3, 14, 0]), np.ones(1, bool)) == []
    assert not det.may_enter(-30, -30, -20, -20)
    assert det.may_enter(math.nan, 0, 1, 1)                     # NaN never rejects
    assert not ZoneDetector([]).may_enter(0, 0, 1, 1)
