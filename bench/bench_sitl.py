"""Real-time factor of ArduPilot SITL UAVs in lock-step, and where the wall time goes.

Usage::

    ARDUPILOT_SITL=../shared/sitl/arducopter python bench/bench_sitl.py            # 1 and 4 UAVs
    python bench/bench_sitl.py --sizes 1 --stop 60 --kernel python                 # the physics' Python twin
    python bench/bench_sitl.py --sizes 1,4 --threads 1,4                            # concurrent doSteps

Each size runs with each ``--threads`` value (the master's ``threads`` setting, capped at the number of UAVs:
the doSteps of one master step run concurrently, docs/coupling.md).

For N UAVs: a scenario of N SITL UAVs (lock-step, strategy B), each with one target 60 m out in its own
direction and a 10 m takeoff, run in this process with ``master.execution.Execution`` (results written to a
temporary folder).  Measured with perf_counter: the initialisation (SITL start and get-ready, ~42 s of vehicle
time each, before t = 0), the step loop, and per UAV inside its FMU: time waiting for the firmware's next servo
frame (``LockstepPhysics.timing['wait']``: the firmware runs), the physics kernel and its socket calls
(``physics`` + ``io``), and the rest of the adapter (MAVLink, set-points: ``step`` minus those).  The master's
share is the loop time minus the FMUs' steps (not shown with threads > 1: the UAVs' steps overlap, and the
firmware/physics/adapter shares, summed over the UAVs, may then exceed 100 %).  RTF = simulated seconds / wall
seconds.  One table is printed.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BASE = (-7.275, -35.965, 540.0)


def scenario(n: int, stop: float, out: Path) -> Path:
    from uavsim.geodesy import EnuFrame
    from uavstudy.build import build_ssp
    from uavstudy.scenario import SitlOptions, UavScenario
    fr = EnuFrame(*BASE)
    pts = [(60.0 * math.sin(2 * math.pi * k / n), 60.0 * math.cos(2 * math.pi * k / n)) for k in range(n)]
    targets = [fr.to_geodetic(x, y, 0.0)[:2] for x, y in pts]
    scn = UavScenario(name=f"bench_sitl_{n}", base=BASE, n_uavs=n, strategy="B", targets=targets,
                      takeoff_altitude=10.0, stop_time=stop, vehicle="sitl", sitl=SitlOptions(coupling="lockstep"))
    return build_ssp(scn, out / f"bench_sitl_{n}.ssp")


def measure(n: int, stop: float, threads: int = 1) -> dict:
    from master.execution import Execution
    with tempfile.TemporaryDirectory(prefix="bench_sitl_") as tmp:
        ssp = scenario(n, stop, Path(tmp))
        ex = Execution(ssp, output=Path(tmp) / "out", write_csv=False, threads=threads)
        w0 = time.perf_counter()
        ex.initialize()
        w1 = time.perf_counter()
        vehicles = [s.obj._vehicle for s in ex.rt.slaves if getattr(getattr(s, "obj", None), "_vehicle", None)]
        ready = [v.ready_time for v in vehicles]
        # get-ready already spent frames: count from here
        before = [(dict(v.physics.timing), v.timing["step"]) for v in vehicles]
        try:
            ex.simulate_until()
            w2 = time.perf_counter()
            sim = ex.time
            tot = {"wait": 0.0, "physics": 0.0, "step": 0.0}
            for v, (pt0, st0) in zip(vehicles, before):
                pt = v.physics.timing
                tot["wait"] += pt["wait"] - pt0["wait"]
                tot["physics"] += pt["physics"] + pt["io"] - pt0["physics"] - pt0["io"]
                tot["step"] += v.timing["step"] - st0
        finally:
            ex.close("completed")
    loop = w2 - w1
    # the get-ready part of the firmware/physics timings happened in initialize(): only the loop's are shown
    return {"n": n, "threads": threads, "init_s": w1 - w0, "ready_sim_s": sum(ready) / len(ready), "loop_s": loop,
            "sim_s": sim, "rtf": sim / loop, "rtf_ready": (sum(ready) / len(ready)) / (w1 - w0), "tot": tot}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,4")
    ap.add_argument("--stop", type=float, default=60.0, help="mission seconds simulated after get-ready")
    ap.add_argument("--kernel", choices=("compiled", "python"), default="compiled")
    ap.add_argument("--threads", default="1", help="comma-separated thread counts (each capped at the UAVs)")
    a = ap.parse_args(argv)
    if a.kernel == "python":
        os.environ["COSIM_MASTER_PURE_PYTHON"] = "1"
    if not os.environ.get("ARDUPILOT_SITL"):
        os.environ["ARDUPILOT_SITL"] = str(REPO.parent / "shared" / "sitl" / "arducopter")
    sys.path.insert(0, str(REPO / "fmu_sources"))
    rows = []
    for n in map(int, a.sizes.split(",")):
        for th in sorted({min(int(x), n) for x in a.threads.split(",")}):
            rows.append(measure(n, a.stop, th))
    print(f"# SITL lock-step, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.1f}, kernel {a.kernel}")
    print("| UAVs | threads | get-ready (sim s / wall s / RTF) | mission sim s | loop wall s | RTF | firmware | "
          "physics | adapter | master |")
    print("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        t, loop = r["tot"], r["loop_s"]
        fw = t["wait"]
        share = {"firmware": fw, "physics": t["physics"], "adapter": t["step"] - fw - t["physics"],
                 "master": loop - t["step"]}
        print(f"| {r['n']} | {r['threads']} | {r['ready_sim_s']:.1f} / {r['init_s']:.1f} / {r['rtf_ready']:.1f}x | "
              f"{r['sim_s']:.0f} | {loop:.1f} | {r['rtf']:.1f}x | "
              + " | ".join(f"{100 * share[k] / loop:.0f} %" for k in ("firmware", "physics", "adapter")) + " | "
              # concurrent steps: the UAVs' times overlap, so the loop minus their sum means nothing
              + (f"{100 * share['master'] / loop:.0f} %" if r["threads"] == 1 else "-") + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
