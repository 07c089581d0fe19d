"""Wall time and real-time factor of the UAV surveillance mission (paper area, step 0.1 s).

Usage: python bench/bench_uav_mission.py [--repeats N] [--scenarios free_4uav_B,free_1uav_B,...]

Builds each scenario from ssp/scenarios/*.yaml into a temporary folder (so the bench does not depend
on the shipped archives), runs it with ``master.runner.run`` (results written to a temporary folder,
UAV monitor and its outputs included) and prints: UAVs, master steps, simulated seconds, wall
seconds (best of N), real-time factor = simulated s / wall s, per-step cost, and the mission outcome
(UAVs successful, collisions, time of the last landing or removal).  Note that a UAV removed by a collision stops stepping, so a mission
that ends in collisions early runs faster than a full one.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from master.runner import run  # noqa: E402
from uavstudy.build import build_ssp  # noqa: E402
from uavstudy.scenario import load_scenario_yaml  # noqa: E402

AREAS = {"free": ROOT / "ssp" / "scenarios" / "paper_area.yaml",
         "zones": ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml"}
DEFAULT = "free_4uav_B,free_1uav_B,zones_4uav_B"


def parse(name: str):
    area, n, strategy = name.split("_")
    return area, int(n.removesuffix("uav")), strategy


def mission_end(events) -> float:
    """Time of the last landing or removal (the simulation goes on to the stop time regardless)."""
    ends = [e["time"] for e in events if e.get("type") in ("uav", "zone")
            or e.get("event") in ("landed_base", "landed_away")]
    return max(ends) if ends else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--scenarios", default=DEFAULT, help=f"comma-separated AREA_NuAV_S (default {DEFAULT})")
    ap.add_argument("--step", type=float, default=0.1)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_uav_") as tmp:
        tmp = Path(tmp)
        for name in args.scenarios.split(","):
            area, n, strategy = parse(name.strip())
            scn = dataclasses.replace(load_scenario_yaml(AREAS[area]), name=f"paper_{name}", n_uavs=n,
                                      strategy=strategy, step=args.step)
            ssp = build_ssp(scn, tmp / f"{name}.ssp")
            best, meta, events = None, None, []
            for r in range(args.repeats):
                t0 = time.perf_counter()
                res = run(ssp, output=tmp / f"out_{name}_{r}", raise_on_error=False)
                wall = time.perf_counter() - t0
                if best is None or wall < best:
                    best, meta, events = wall, res.metadata, res.events
            sim = meta["stop_time"] - meta["start_time"]
            tot = meta.get("monitors", {}).get("org.cosim-master.uav-monitor", {}).get("total", {})
            rows.append((name, n, meta["steps"], sim, best, sim / best, 1e6 * best / meta["steps"],
                         f"{tot.get('uavs_successful', '?')}/{n}", tot.get("uav_collisions", "?"),
                         tot.get("zone_collisions", "?"), mission_end(events), meta["outcome"]))
    hdr = ("scenario", "UAVs", "steps", "sim s", "wall s", "RTF", "us/step", "success", "uav coll", "zone coll",
           "mission end s", "run")
    print(f"{hdr[0]:<14}{hdr[1]:>5}{hdr[2]:>8}{hdr[3]:>8}{hdr[4]:>9}{hdr[5]:>8}{hdr[6]:>9}{hdr[7]:>9}"
          f"{hdr[8]:>9}{hdr[9]:>10}{hdr[10]:>15}  {hdr[11]}")
    for r in rows:
        print(f"{r[0]:<14}{r[1]:>5}{r[2]:>8}{r[3]:>8.0f}{r[4]:>9.2f}{r[5]:>8.1f}{r[6]:>9.0f}{r[7]:>9}{r[8]!s:>9}"
              f"{r[9]!s:>10}{r[10]:>15.1f}  {r[11]}")
    print(f"(python {sys.version.split()[0]}, {os.cpu_count()} CPUs; RTF = simulated s / wall s, wall includes "
          "FMU loading and the UAV outputs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
