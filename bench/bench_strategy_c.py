"""Speed of strategy C (docs/cooperative.md) against B: the issue's two goals, measured in one run.

Usage::

    python bench/bench_strategy_c.py                 # 5 runs of each 4-UAV mission, 3 of each 64-UAV fleet
    python bench/bench_strategy_c.py --reps 9 --reps-64 0     # the 4-UAV missions only

1. The shipped 4-UAV missions: ``ssp/paper_zones_4uav_B.ssp`` (B) and ``ssp/coop_zones_4uav_C.ssp`` (C, the same
   area, targets, wind and seed, plus the channel: 300 m, 0.5 s period, 0.2 s latency, 10 % loss, k = 4, line of
   sight).  Each run is a fresh child process (``--child``) doing what ``cosim-master run`` does in-process
   (``master.runner.run`` with an output folder): its CPU time (user + system, from ``getrusage`` of the
   children) and wall time.  "warm" is a second run in the same process (FMUs unpacked, plans reused), the cost
   per mission of a campaign worker.  B and C runs alternate (B, C, B, C, ...), so that both see the same load;
   the table gives the median of ``--reps`` runs of each and the ratios of the medians.  Goal: C within 1.5x the
   CPU of B.
2. A 64-UAV fleet, B and C: 64 targets (one per UAV, the most the strategy FMU's indexed parameters take) in the
   annulus 150-700 m about the base, listed clockwise like the pads of the ring (so ``equal`` assignment sends
   each UAV out in front of its pad), no zones, no wind, step 0.1 s, the channel as in 1 without zones.
   Real-time factor = simulated time / wall time of the run (and / its CPU time: what an unloaded machine
   would give), the median of ``--reps-64`` alternating runs.  Goal: C at least 20x real time.

The machine may be shared: the load average (1 min) is printed before and after each part; CPU time is what a
run costs whatever the load, wall time is not.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from timed_process import run_timed  # bench/ is the script's folder, first on sys.path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BASE = (-7.275, -35.965, 540.0)
MISSIONS = {"B": ROOT / "ssp" / "paper_zones_4uav_B.ssp", "C": ROOT / "ssp" / "coop_zones_4uav_C.ssp"}


def fleet_scenario(n: int, strategy: str, stop_time: float):
    import numpy as np

    from uavsim.geodesy import geodetic_from_enu
    from uavstudy.scenario import CommConfig, UavScenario, WindConfig
    rng = np.random.default_rng(64)
    pts = sorted((rng.uniform(0.0, 2 * math.pi), math.sqrt(rng.uniform(150.0 ** 2, 700.0 ** 2))) for _ in range(n))

    def ll(a, r):
        la, lo, _ = geodetic_from_enu(r * math.sin(a), r * math.cos(a), 0.0, *BASE)
        return (round(float(la), 7), round(float(lo), 7))
    return UavScenario(name=f"fleet_{n}uav_{strategy}", base=BASE, n_uavs=n, strategy=strategy, assignment="equal",
                       targets=[ll(a, r) for a, r in pts], wind=WindConfig(probability=0.0), seed=1, step=0.1,
                       stop_time=stop_time, comm=CommConfig(range=300.0, period=0.5, latency=0.2, loss=0.1, k=4))


def child(args) -> None:
    from master.runner import run
    if args.fleet:
        from uavstudy.build import build_ssp
        path = build_ssp(fleet_scenario(args.fleet, args.strategy, args.stop), Path(args.out) / "fleet.ssp")
    else:
        path = MISSIONS[args.strategy]
    out = {}
    for name in ("cold", "warm"):
        c0, w0 = time.process_time(), time.perf_counter()
        result = run(path, output=Path(args.out) / name)
        out[name] = {"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0,
                     "sim_s": float(result.metadata.get("last_time") or result.metadata.get("end_time") or 0.0)}
        summary = json.loads((Path(args.out) / name / "summary.json").read_text())["total"]
        out[name].update({"uav_collisions": summary["uav_collisions"], "successes": summary["uavs_successful"],
                          "end_time": summary["end_time"]})
        if args.fleet:
            break
    print(json.dumps(out))


def measure(strategy: str, fleet: int = 0, stop: float = 0.0) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench_c_") as tmp:
        cmd = [sys.executable, __file__, "--child", "--strategy", strategy, "--out", tmp]
        if fleet:
            cmd += ["--fleet", str(fleet), "--stop", str(stop)]
        done, wall, cpu = run_timed(cmd, env={**os.environ, "PYTHONPATH": str(ROOT)})
        if done.returncode:
            raise SystemExit(done.stderr[-2000:])
        out = json.loads(done.stdout.strip().splitlines()[-1])
        out["process_cpu_s"] = cpu
        out["process_wall_s"] = wall
        return out


def _load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def _alternating(reps: int, run) -> dict:
    """``run(strategy)`` for B then C, ``reps`` times: each strategy's results in order."""
    out = {"B": [], "C": []}
    for _ in range(reps):
        for s in out:
            out[s].append(run(s))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=5, help="runs of each 4-UAV mission (alternating B and C)")
    ap.add_argument("--reps-64", type=int, default=3, help="runs of each 64-UAV fleet (0: none)")
    ap.add_argument("--stop-64", type=float, default=300.0, help="stop time of the 64-UAV runs (s)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--strategy", default="C", help=argparse.SUPPRESS)
    ap.add_argument("--fleet", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--stop", type=float, default=0.0, help=argparse.SUPPRESS)
    ap.add_argument("--out", default="", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args)
        return 0
    if args.reps > 0:
        load0 = _load()
        runs = _alternating(args.reps, measure)
        rows = {}
        for s, rs in runs.items():
            rows[s] = {"process": statistics.median(r["process_cpu_s"] for r in rs),
                       "cold": statistics.median(r["cold"]["cpu_s"] for r in rs),
                       "warm": statistics.median(r["warm"]["cpu_s"] for r in rs),
                       "wall": statistics.median(r["cold"]["wall_s"] for r in rs),
                       "end": rs[0]["cold"]["end_time"], "coll": rs[0]["cold"]["uav_collisions"],
                       "succ": rs[0]["cold"]["successes"]}
        print(f"4-UAV missions (CPU s, median of {args.reps} alternating runs; load {load0} -> {_load()})")
        print(f"{'':4} {'process':>8} {'run cold':>9} {'run warm':>9} {'wall':>6} {'sim end s':>10} {'UAV coll':>9} "
              f"{'successes':>9}")
        for s, r in rows.items():
            print(f"{s:4} {r['process']:8.2f} {r['cold']:9.2f} {r['warm']:9.2f} {r['wall']:6.2f} {r['end']:10.1f} "
                  f"{r['coll']:9d} {r['succ']:9d}")
        b, c = rows["B"], rows["C"]
        print(f"C / B CPU: process {c['process'] / b['process']:.2f}x, run cold {c['cold'] / b['cold']:.2f}x, "
              f"run warm {c['warm'] / b['warm']:.2f}x  (goal <= 1.5x)")
        print()
    if args.reps_64 > 0:
        load0 = _load()
        runs = _alternating(args.reps_64, lambda s: measure(s, 64, args.stop_64)["cold"])
        print(f"64-UAV fleet, step 0.1 s, {args.stop_64:g} s simulated (median of {args.reps_64} alternating runs; "
              f"load {load0} -> {_load()})")
        print(f"{'':4} {'wall s':>7} {'CPU s':>7} {'x real time':>12} {'(on CPU)':>9}")
        for s, rs in runs.items():
            wall = statistics.median(r["wall_s"] for r in rs)
            cpu = statistics.median(r["cpu_s"] for r in rs)
            sim = rs[0]["end_time"]
            print(f"{s:4} {wall:7.2f} {cpu:7.2f} {sim / wall:12.1f} {sim / cpu:9.1f}")
        print("goal: C >= 20x real time (wall; on a shared machine wall exceeds CPU by the time spent waiting for a "
              "core: the CPU column is the factor of an unloaded machine)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
