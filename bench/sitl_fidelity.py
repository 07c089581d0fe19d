"""Two fidelities of one mission: the same scenario flown by the point-mass model and by ArduPilot SITL.

Usage::

    ARDUPILOT_SITL=../shared/sitl/arducopter python bench/sitl_fidelity.py [scenario.yaml] [--figure PATH]

Runs the scenario (default ssp/scenarios/sitl_zones_1uav_B.yaml) twice with everything equal but
``vehicle`` (point_mass, then sitl in lock-step), prints one table from the runs' summary.json and
events.csv (path length, flight time, energy, targets, photos, collisions, outcome) and draws the two
trajectories (plan view, height and ground speed over time) into the figure (default
docs/sitl_fidelity.png).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def fly(scn, vehicle: str, out: Path):
    import master
    from uavstudy.build import build_ssp
    s = dataclasses.replace(scn, vehicle=vehicle, name=f"{scn.name}_{vehicle}")
    ssp = build_ssp(s, out / f"{vehicle}.ssp")
    res = master.run(ssp, output=out / vehicle, raise_on_error=True, write_csv=False)
    summary = json.loads((out / vehicle / "summary.json").read_text())
    events = (out / vehicle / "events.csv").read_text().splitlines()
    collisions = sum(1 for e in events if ",uav_collision," in e or ",zone_collision," in e)
    return res.frame, summary, collisions


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default=str(REPO / "ssp" / "scenarios" / "sitl_zones_1uav_B.yaml"))
    ap.add_argument("--figure", default=str(REPO / "docs" / "sitl_fidelity.png"))
    a = ap.parse_args(argv)
    os.environ.setdefault("ARDUPILOT_SITL", str(REPO.parent / "shared" / "sitl" / "arducopter"))
    from uavstudy.scenario import load_scenario_yaml
    scn = load_scenario_yaml(a.scenario)
    rows = {}
    with tempfile.TemporaryDirectory(prefix="sitl_fidelity_") as tmp:
        for vehicle in ("point_mass", "sitl"):
            frame, summary, coll = fly(scn, vehicle, Path(tmp))
            u = summary["uavs"][0]
            rows[vehicle] = {"frame": frame, "u": u, "collisions": coll}
    print(f"# {scn.name}: point-mass vs ArduPilot SITL (lock-step)")
    print("| | path m | horizontal m | flight time s | energy Wh | targets | photos | collisions | outcome |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
    for vehicle, r in rows.items():
        u = r["u"]
        print(f"| {vehicle} | {u['distance_m']:.1f} | {u['distance_xy_m']:.1f} | {u['flight_time_s']:.1f} | "
              f"{u['energy_used_Wh']:.2f} | {u['targets_visited']}/{u['targets_assigned']} | {u['photos']} | "
              f"{r['collisions']} | {u['outcome']} |")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    for vehicle, r in rows.items():
        f = r["frame"]
        ax[0].plot(f["uav1_dyn.x"], f["uav1_dyn.y"], label=vehicle)
        ax[1].plot(f["time"], f["uav1_dyn.z"], label=vehicle)
        ax[2].plot(f["time"], f["uav1_dyn.groundspeed"], label=vehicle)
    for z in scn.zones_enu():
        p = z["polygon"]
        ax[0].fill(p[:, 0], p[:, 1], color="red", alpha=0.2)
    t = scn.targets_enu()
    ax[0].plot(t[:, 0], t[:, 1], "k^", label="targets")
    ax[0].set(xlabel="east m", ylabel="north m", title="plan view", aspect="equal")
    ax[1].set(xlabel="mission time s", ylabel="height m", title="height")
    ax[2].set(xlabel="mission time s", ylabel="m/s", title="ground speed")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.figure, dpi=90)
    print(f"figure: {a.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
