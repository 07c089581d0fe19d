"""CPU of one lock-step SITL vehicle (firmware + physics + adapter) under the vehicle's opt-in options.

Usage::

    ARDUPILOT_SITL=../shared/sitl/arducopter python bench/bench_sitl_options.py              # 3 rounds, 20 s flown
    python bench/bench_sitl_options.py --rounds 5 --fly 0                                    # the get-ready alone

Variants (``SitlConfig``, fmu_sources/sitlsim/vehicle.py): ``default`` (the shipped FMU: 1200 frames/s, ground-station
ports open), ``headless`` (``gcs_port`` false: no SERIAL1/SERIAL2), ``rate400`` (``frame_rate`` 400 with
SCHED_LOOP_RATE 200, which the firmware needs to arm at that rate) and ``lean`` (both: what the SITL tests fly,
tests/sitlveh_helpers.py ``lean_sitl``).  Each measurement is a fresh child process that starts the vehicle, gets it
ready (~42 s of vehicle time) and flies a take-off and a leg 36 m out for ``--fly`` s in steps of 0.1 s; its CPU is
user + system of the child and of the firmware it reaped (bench/timed_process.py).  Rounds alternate the variants,
so each round's variants meet the same load.  ``same flight`` compares the trajectory (x, y, z, phase after every
step) with the default variant's of the same round: headless must be the same flight, a lower frame rate is not.
One table is printed.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from timed_process import run_timed  # noqa: E402

VARIANTS = {
    "default": {},
    "headless": {"gcs_port": False},
    "rate400": {"frame_rate": 400, "params": {"SCHED_LOOP_RATE": 200.0}},
    "lean": {"frame_rate": 400, "gcs_port": False, "params": {"SCHED_LOOP_RATE": 200.0}},
}
BASE = (-7.275, -35.965, 540.0, 0.0)

CHILD = r'''
import hashlib, json, sys, tempfile
sys.path.insert(0, sys.argv[1])
from sitlsim.vehicle import SitlConfig, SitlVehicle
options, fly, base = json.loads(sys.argv[2]), float(sys.argv[3]), tuple(json.loads(sys.argv[4]))
with tempfile.TemporaryDirectory(prefix="bench-sitl-options-") as wd:
    v = SitlVehicle(SitlConfig(workdir=wd, home=base, takeoff_altitude=5.0, **options), (0.0, 0.0))
    try:
        v.start()
        track, t = [], 0.0
        while t < fly - 1e-9:
            v.step(t, 0.1, 1 if t < 8.0 else 2, (30.0, 20.0, 5.0), (0.0, 0.0, 0.0))
            t += 0.1
            track.append((tuple(v.pos), v.phase))
        print(json.dumps({"ready_time": v.ready_time, "frames": v.physics.frames_answered,
                          "track": hashlib.sha256(repr(track).encode()).hexdigest()}))
    finally:
        v.close()
'''


def measure(variant: str, fly: float) -> dict:
    cmd = [sys.executable, "-c", CHILD, str(REPO / "fmu_sources"), json.dumps(VARIANTS[variant]), str(fly),
           json.dumps(BASE)]
    proc, wall, cpu = run_timed(cmd, cwd=REPO)
    if proc.returncode != 0:
        raise SystemExit(f"{variant}: the child failed: {proc.stderr.strip().splitlines()[-1:]}")
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "cpu": cpu, "wall": wall}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--fly", type=float, default=20.0, help="mission seconds flown after the get-ready")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    args = ap.parse_args(argv)
    if not os.environ.get("ARDUPILOT_SITL"):
        os.environ["ARDUPILOT_SITL"] = str(REPO.parent / "shared" / "sitl" / "arducopter")
    names = args.variants.split(",")
    load0 = os.getloadavg()[0]
    rows: dict[str, list[dict]] = {n: [] for n in names}
    same: dict[str, list[bool]] = {n: [] for n in names}
    for k in range(args.rounds):
        order = names if k % 2 == 0 else names[::-1]
        got = {n: measure(n, args.fly) for n in order}
        for n in names:
            rows[n].append(got[n])
            if "default" in got and args.fly > 0:
                same[n].append(got[n]["track"] == got["default"]["track"])
    load1 = os.getloadavg()[0]
    print(f"one lock-step SITL vehicle: get-ready + {args.fly:g} s flown, {args.rounds} alternating rounds, "
          f"load average {load0:.1f} -> {load1:.1f}")
    print()
    print("| variant | CPU s (median; each round) | / default | wall s (median) | ready (vehicle s) | frames answered "
          "| same flight as default |")
    print("|---|---|---:|---:|---:|---:|---|")
    ref = statistics.median(r["cpu"] for r in rows["default"]) if "default" in rows else None
    for n in names:
        cpus = [r["cpu"] for r in rows[n]]
        med = statistics.median(cpus)
        ratio = f"{med / ref:.2f}" if ref else "-"
        flight = ("yes" if all(same[n]) else "no") if same[n] else "-"
        print(f"| {n} | {med:.2f} ({' '.join(f'{c:.2f}' for c in cpus)}) | {ratio} | "
              f"{statistics.median(r['wall'] for r in rows[n]):.2f} | {rows[n][0]['ready_time']:.1f} | "
              f"{rows[n][0]['frames']} | {flight} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
