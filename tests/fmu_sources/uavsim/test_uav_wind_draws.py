"""Wind._draw against an independent reading of its streams: interval k's episode numbers are numbers 2k and 2k + 1
of the episode stream and its gust start number k of the gust stream (each stream drawn in one vector here), so an
interval is the same however (one by one, scalar or vector draws) and whenever it is drawn."""
import struct

import numpy as np

from uavsim.wind import Wind, WindParams


def streams(seed, stream):
    ss = np.random.SeedSequence(seed if stream < 0 else (seed, stream + 1))
    s_ep, s_gust, _ = ss.spawn(3)
    return np.random.Generator(np.random.PCG64(s_ep)), np.random.Generator(np.random.PCG64(s_gust))


def test_intervals_are_the_streams_numbers():
    n = 400
    for seed, stream, probability in [(0, -1, 0.15), (7, 0, 0.5), (7, 3, 0.05), (123456, -1, 0.9)]:
        p = WindParams(seed=seed, stream=stream, probability=probability)
        w = Wind(p)
        w._interval(n - 1)
        ep, gust = streams(seed, stream)
        u, g = ep.random(2 * n), gust.random(n)
        levels = set()
        for k in range(n):
            iv = w.intervals[k]
            occurs = bool(u[2 * k] < probability)
            if not occurs:
                level, speed = 0, 0.0
            elif u[2 * k + 1] < p.p_weak:
                level, speed = 1, p.speed_weak
            elif u[2 * k + 1] < p.p_weak + p.p_moderate:
                level, speed = 2, p.speed_moderate
            else:
                level, speed = 3, p.speed_strong
            assert (iv.occurs, iv.level, iv.speed) == (occurs, level, speed), (seed, stream, k)
            assert type(iv.gust_start) is float and struct.pack("d", iv.gust_start) == struct.pack("d", g[k])
            levels.add(level)
        assert w.occurs == [w.intervals[k].occurs for k in range(n)]
        assert levels == {0, 1, 2, 3} or probability < 0.1
