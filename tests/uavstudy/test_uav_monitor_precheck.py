"""The monitor's skip test (uavstudy/geometry.py, "Skipping steps that provably hold no event") never hides an
event: the bound against the exact swept-sphere computation and the exact zone check where it is tight (hand
constructions).  The whole monitor with the skip (uavstudy.monitor_fast) against the reference step is the
accelerator harness's (tests/accelerators/, cases from uavstudy.monitor_accel)."""
import math

import numpy as np

from uavstudy.geometry import SKIP_REL, CollisionDetector, ZoneDetector, pair_clearances


D = 2.6


def test_pair_bound_is_sound_where_it_is_tight():
    """Head-on: two UAVs d0 apart close at l each over one step, so the minimum distance is d0 - 2l (hand
    computation; the triangle-inequality bound is exact here).  Gaps d0 - 2l - D within +-1 cm of zero, on
    random lines and at map coordinates up to 1e5 m: whenever the skip test says 'apart', the exact
    narrow phase finds no contact."""
    rng = np.random.default_rng(15)
    det = CollisionDetector(D)
    skipped = contacts = 0
    for _ in range(4000):
        centre = rng.uniform(-1e5, 1e5, 3)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        l = rng.uniform(0.0, 20.0)
        gap = rng.uniform(-0.01, 0.01)
        d0 = D + 2 * l + gap
        a0, b0 = centre - 0.5 * d0 * u, centre + 0.5 * d0 * u
        a1, b1 = a0 + l * u, b0 - l * u
        p0, p1 = np.array([a0, b0]), np.array([a1, b1])
        clear = pair_clearances(p0.tolist(), D)[0][1]
        ta, tb = math.dist(a0, a1), math.dist(b0, b1)
        skip = clear - (ta + tb) * (1.0 + SKIP_REL) > 0.0
        hit = bool(det.check_bruteforce(0.0, 1.0, p0, p1))
        assert not (skip and hit), (centre, u, l, gap)
        skipped += skip
        contacts += hit
        if gap < -1e-6:     # the hand computation: closer than D at the end of the step
            assert hit
    assert skipped > 1000 and contacts > 1000       # both sides of the boundary were exercised


def test_zone_bound_is_sound_near_a_box():
    """Segments that end within +-1 cm of a zone's edge, coming from outside nearly head-on (where the
    distance to the box shrinks by the whole travel): 'apart' never coexists with an incursion, and a
    segment ending 1 mm or more inside is an incursion (hand reasoning: the end point is in the zone)."""
    rng = np.random.default_rng(16)
    zd = ZoneDetector([[(0, 0), (40, 0), (40, 30), (0, 30)]], ["box"])
    edges = [((0, 0), (40, 0), (0, -1)), ((40, 0), (40, 30), (1, 0)), ((40, 30), (0, 30), (0, 1)),
             ((0, 30), (0, 0), (-1, 0))]      # (from, to, outward normal)
    skipped = hits = 0
    for _ in range(3000):
        (ax, ay), (bx, by), (nx, ny) = edges[rng.integers(4)]
        f = rng.uniform(0.05, 0.95)
        gap = rng.uniform(-0.01, 0.01)                 # > 0: the segment stops short of the edge
        ex, ey = ax + f * (bx - ax) + gap * nx, ay + f * (by - ay) + gap * ny
        ang = rng.uniform(-0.3, 0.3) if rng.random() < 0.5 else 0.0   # 0: the bound is exact
        dx, dy = nx * math.cos(ang) - ny * math.sin(ang), nx * math.sin(ang) + ny * math.cos(ang)
        l = rng.uniform(0.0, 30.0)
        sx, sy = ex + l * dx, ey + l * dy
        p0, p1 = np.array([[sx, sy, 20.0]]), np.array([[ex, ey, 20.0]])
        skip = zd.clearance(sx, sy) - math.dist(p0[0], p1[0]) * (1.0 + SKIP_REL) > 0.0
        hit = bool(zd.check(0.0, 1.0, p0, p1))
        assert not (skip and hit), (sx, sy, ex, ey)
        if gap < -1e-3:
            assert hit
        skipped += skip
        hits += hit
    assert skipped > 300 and hits > 1000
