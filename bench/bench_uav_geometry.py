"""Time per CollisionDetector/ZoneDetector check for N UAVs at random spread positions.

Usage: python bench/bench_uav_geometry.py [repeats]

Vehicles are spread uniformly over a square whose side grows with sqrt(N)
(about 1 UAV per 60 m x 60 m, i.e. the 1.2 km x 1.2 km study area holds
~400), at 10 m altitude +-1 m, moving ~7 m (random direction) per 1 s step.
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from uavstudy.geometry import CollisionDetector, ZoneDetector  # noqa: E402


def make_steps(n, steps, rng):
    side = 60.0 * np.sqrt(n)
    p = np.column_stack((rng.uniform(0, side, (n, 2)), rng.uniform(9, 11, n)))
    v = rng.normal(0, 5, (n, 3)) * [1, 1, 0.05]
    out = [p.copy()]
    for _ in range(steps):
        p = p + v
        out.append(p.copy())
    return out, side


def timeit(fn, pos, active, steps):
    t = time.perf_counter()
    hits = 0
    for k in range(steps):
        hits += len(fn(k, k + 1.0, pos[k], pos[k + 1], active))
    return (time.perf_counter() - t) / steps, hits


def main():
    steps = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    rng = np.random.default_rng(0)
    print(f"{'N':>6} {'collision us':>13} {'brute us':>10} {'zones us':>10} "
          f"{'cand/N':>7} {'s per 10k steps':>16}")
    for n in (4, 64, 256, 1024):
        pos, side = make_steps(n, steps, rng)
        active = np.ones(n, bool)
        det = CollisionDetector(2.6)
        # 4 zones of ~100 m x 100 m inside the area
        c = side / 2
        zones = [[(c + dx, c + dy), (c + dx + 100, c + dy), (c + dx + 100, c + dy + 100),
                  (c + dx, c + dy + 100)] for dx, dy in ((-300, -300), (200, -300),
                                                         (-300, 200), (200, 200))]
        zdet = ZoneDetector(zones, ["z1", "z2", "z3", "z4"])
        tc, _ = timeit(det.check, pos, active, steps)
        cand = det.last_candidate_count
        bsteps = steps if n <= 256 else max(5, steps // 20)
        tb, _ = timeit(det.check_bruteforce, pos, active, bsteps)
        tz, _ = timeit(zdet.check, pos, active, steps)
        print(f"{n:>6} {tc * 1e6:>13.0f} {tb * 1e6:>10.0f} {tz * 1e6:>10.0f} "
              f"{cand / n:>7.2f} {(tc + tz) * 1e4:>16.2f}")


if __name__ == "__main__":
    main()
