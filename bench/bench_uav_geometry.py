"""Time per CollisionDetector/ZoneDetector check for N UAVs at random spread positions, and per step of the
UAV monitor.

Usage: python bench/bench_uav_geometry.py [steps]
       python bench/bench_uav_geometry.py --monitor [rounds]

--monitor: the monitor's ``after_step`` (uavstudy.monitor) on a synthetic mission of N UAVs flying circles
of 40 m around spread centres at 8 m/s, 20 m up, with a restricted zone, at 0.1 s (N = 4) and 1 s steps:
CPU time (time.process_time) per step of the accelerated step with its C step (the default; C for N <= 16),
of the accelerated step in Python only, and of the reference step (``uavstudy.monitor_step``, what
``COSIM_MASTER_PURE_PYTHON=1`` runs); the minimum over the rounds, the buffer loading subtracted.  N > 16
takes the reference's vector step in the first two (with idle steps).

Vehicles are spread uniformly over a square whose side grows with sqrt(N)
(about 1 UAV per 60 m x 60 m, i.e. the 1.2 km x 1.2 km study area holds
~400), at 10 m altitude +-1 m, moving ~7 m (random direction) per 1 s step.
"""
from __future__ import annotations

import math
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


class _Ctx:
    """The part of the master's observer context the monitor uses: one buffer per base type."""

    def __init__(self, names, roles):
        self.pos, nr, ni = {}, 0, 0
        for n in names:
            for role in roles:
                if role == "phase":
                    self.pos[f"{n}.{role}"] = ("Integer", ni)
                    ni += 1
                else:
                    self.pos[f"{n}.{role}"] = ("Real", nr)
                    nr += 1
        self.buf = {"Real": np.zeros(nr), "Integer": np.zeros(ni, dtype=np.int32)}
        self.events = []

    def position(self, q):
        return self.pos[q]

    def buffer(self, typ):
        return self.buf[typ]

    def deactivate(self, comps):
        pass

    def emit(self, event):
        self.events.append(event)

    def request_stop(self, reason):
        pass


def monitor_bench(rounds: int) -> None:
    from lxml import etree

    from uavstudy.monitor import MONITOR_TYPE, UavMonitor
    from uavstudy.monitor_fast import AcceleratedStep, c_step_function
    from uavstudy.monitor_step import ReferenceStep
    factories = {"C": lambda mon: AcceleratedStep(mon, c_step_function()),
                 "Python": lambda mon: AcceleratedStep(mon, None), "reference": ReferenceStep}
    roles = ("x", "y", "z", "phase")
    print(f"{'N':>4} {'step s':>6} {'steps':>6} {'C us/step':>10} {'Python us/step':>15} {'reference us/step':>18}")
    for n, h, steps in ((4, 0.1, 6000), (16, 1.0, 1500), (64, 1.0, 400)):
        names = [f"u{k}" for k in range(n)]
        side = 120.0 * math.ceil(math.sqrt(n))
        centres = [(120.0 * (k % math.ceil(math.sqrt(n))), 120.0 * (k // math.ceil(math.sqrt(n)))) for k in range(n)]
        uavs = "".join(f'<uav:Uav name="{u}" components="{u}_dyn" '
                       + " ".join(f'{r}="{u}.{r}"' for r in roles) + "/>" for u in names)
        zone = f"{side},{-50} {side + 100},{-50} {side + 100},{side} {side},{side}"
        xml = (f'<ssc:Annotation xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
               f'type="{MONITOR_TYPE}"><uav:UavMonitor xmlns:uav="https://cosim-master.org/ssp/uav">{uavs}'
               f'<uav:Zone name="z">{zone}</uav:Zone></uav:UavMonitor></ssc:Annotation>')
        t = h * np.arange(steps + 1)[:, None]
        ang = 0.2 * t + np.arange(n)[None, :]
        cx, cy = np.array(centres).T
        xyz = np.stack((cx + 40 * np.cos(ang), cy + 40 * np.sin(ang), np.full(ang.shape, 20.0)), axis=2)
        cols = {}
        for mode in ("C", "Python", "reference"):
            best = math.inf
            for _ in range(rounds):
                mon = UavMonitor(etree.fromstring(xml), None, "bench")
                mon.step_factory = factories[mode]
                ctx = _Ctx(names, roles)
                real, pos = ctx.buf["Real"], [[ctx.pos[f"{u}.{r}"][1] for r in "xyz"] for u in names]
                pos = np.array(pos)
                ctx.buf["Integer"][:] = 2
                real[pos] = xyz[0]
                mon.attach(ctx, 0.0)
                c = time.process_time()
                for k in range(1, steps + 1):
                    real[pos] = xyz[k]
                load = time.process_time() - c
                real[pos] = xyz[0]
                c = time.process_time()
                for k in range(1, steps + 1):
                    real[pos] = xyz[k]
                    mon.after_step(k - 1, h * (k - 1), h * k)
                best = min(best, (time.process_time() - c - load) / steps)
            cols[mode] = best * 1e6
        print(f"{n:>4} {h:>6} {steps:>6} {cols['C']:>10.2f} {cols['Python']:>15.2f} {cols['reference']:>18.2f}")


def main():
    if "--monitor" in sys.argv:
        rest = [a for a in sys.argv[1:] if a != "--monitor"]
        monitor_bench(int(rest[0]) if rest else 5)
        return
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
