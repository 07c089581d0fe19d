"""Build the shipped SSP archives of the paper study from ssp/scenarios/*.yaml.

    python ssp/build_all.py [--all] [--fmus DIR] [--out DIR]

Writes ``paper_{free,zones}_{N}uav_{A,B}.ssp``: area ``free`` = ssp/scenarios/paper_area.yaml (no
restricted zones), ``zones`` = paper_area_zones.yaml (4 restricted zones), N = 1..4 UAVs, strategy A or
B; everything else (24 targets, base, wind, seed, step, stop time) as in the YAML file.  Each archive
holds the four UAV FMUs once (~0.73 MB each, shared by all instances), i.e. ~3 MB per archive.

It also writes the SITL scenarios ``sitl_zones_{1,4}uav_B.ssp`` and strategy C's ``coop_zones_4uav_C.ssp``
(docs/cooperative.md) from their own YAML files (``AS_IS``).

By default only the representative set (N = 1 and 4, 8 archives, ~24 MB) is written, since all 16
(~47 MB) are too big to commit; ``--all`` writes the 16.  Any other variant is one command away::

    cosim-master build-scenario ssp/scenarios/paper_area_zones.yaml -o my.ssp   # after editing a copy
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
AREAS = {"free": HERE / "scenarios" / "paper_area.yaml", "zones": HERE / "scenarios" / "paper_area_zones.yaml"}
REPRESENTATIVE_UAVS = (1, 4)


#: scenarios shipped as they are (ArduPilot SITL vehicles, docs/sitl.md): ssp/scenarios/<name>.yaml -> ssp/<name>.ssp
AS_IS = ("sitl_zones_1uav_B", "sitl_zones_4uav_B", "coop_zones_4uav_C")


def variants(all_counts: bool):
    counts = (1, 2, 3, 4) if all_counts else REPRESENTATIVE_UAVS
    for area in AREAS:
        for n in counts:
            for strategy in ("A", "B"):
                yield area, n, strategy


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--all", action="store_true", help="all 16 archives (1..4 UAVs) instead of 1 and 4 UAVs")
    ap.add_argument("--fmus", default=None, help="folder with the UAV FMUs (default: the repository's fmus/)")
    ap.add_argument("--out", default=str(HERE), help="output folder (default: ssp/)")
    args = ap.parse_args(argv)

    from uavstudy.build import build_ssp
    from uavstudy.scenario import load_scenario_yaml

    out = Path(args.out)
    total = 0
    for area, n, strategy in variants(args.all):
        base = load_scenario_yaml(AREAS[area])
        name = f"paper_{area}_{n}uav_{strategy}"
        # shipped missions end when the fleet has landed (or crashed) instead of idling to the stop time
        scn = dataclasses.replace(base, name=name, n_uavs=n, strategy=strategy, end_when_all_landed=True)
        path = build_ssp(scn, out / f"{name}.ssp", args.fmus)
        size = path.stat().st_size
        total += size
        print(f"{path}  {size / 1e6:.2f} MB")
    for name in AS_IS:
        path = build_ssp(load_scenario_yaml(HERE / "scenarios" / f"{name}.yaml"), out / f"{name}.ssp", args.fmus)
        total += path.stat().st_size
        print(f"{path}  {path.stat().st_size / 1e6:.2f} MB")
    print(f"total {total / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
