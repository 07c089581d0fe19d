"""Two fidelities of one mission: the same scenario flown by the point-mass model and by ArduPilot SITL.

Usage::

    ARDUPILOT_SITL=../shared/sitl/arducopter python bench/sitl_fidelity.py [scenario.yaml] [--figure PATH]
        [--threads N] [--keep DIR]

Runs the scenario (default ssp/scenarios/sitl_zones_1uav_B.yaml; the 4-UAV one is
ssp/scenarios/sitl_zones_4uav_B.yaml) twice with everything equal but ``vehicle`` (point_mass, then sitl in
lock-step), and prints one table per UAV from the runs' summary.json and events.csv (path length, flight
time, energy, targets, photos, collisions, outcome) plus the wall time of each run and, for SITL, the clock
slip run.json records.  The figure (default docs/sitl_fidelity.png; docs/sitl_fidelity_4uav.png for the
4-UAV mission) shows, for one UAV, the two trajectories (plan view, height and ground speed over time); for
a fleet the plan views of both fidelities and the targets photographed over time.
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FIDELITIES = ("point_mass", "sitl")
COLLISIONS = ("uav_collision", "zone_collision")


def fly(scn, vehicle: str, out: Path, threads: int):
    import master
    from uavstudy.build import build_ssp
    s = dataclasses.replace(scn, vehicle=vehicle, name=f"{scn.name}_{vehicle}")
    ssp = build_ssp(s, out / f"{vehicle}.ssp")
    w0 = time.perf_counter()
    res = master.run(ssp, output=out / vehicle, raise_on_error=True, write_csv=False,
                     threads=threads if threads > 1 else None)
    wall = time.perf_counter() - w0
    summary = json.loads((out / vehicle / "summary.json").read_text())
    run_json = json.loads((out / vehicle / "run.json").read_text())
    collisions: dict[str, int] = {}
    events = out / vehicle / "events.csv"
    if events.is_file():
        with events.open() as fh:
            for e in csv.DictReader(fh):
                if e["event"] in COLLISIONS:
                    for who in (e["uav"], e.get("other") or ""):
                        if who:
                            collisions[who] = collisions.get(who, 0) + 1
    return {"frame": res.frame, "summary": summary, "collisions": collisions, "wall": wall, "run": run_json}


def table(scn, rows) -> list[str]:
    lines = [f"# {scn.name}: point-mass vs ArduPilot SITL (lock-step)",
             "| | UAV | path m | horizontal m | flight time s | energy Wh | targets | photos | collisions | outcome |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for vehicle, r in rows.items():
        for u in r["summary"]["uavs"]:
            lines.append(f"| {vehicle} | {u['uav']} | {u['distance_m']:.1f} | {u['distance_xy_m']:.1f} | "
                         f"{u['flight_time_s']:.1f} | {u['energy_used_Wh']:.2f} | "
                         f"{u['targets_visited']}/{u['targets_assigned']} | {u['photos']} | "
                         f"{r['collisions'].get(u['uav'], 0)} | {u['outcome']} |")
    lines.append("")
    lines.append("| | mission end s | wall s | targets | max clock slip s |")
    lines.append("|---|---:|---:|---:|---:|")
    for vehicle, r in rows.items():
        uavs = r["summary"]["uavs"]
        clock = r["run"].get("monitors", {}).get("org.cosim-master.sitl-clock", {}).get("vehicles", {})
        slip = max((v.get("max_slip_s", 0.0) for v in clock.values()), default=None)
        lines.append(f"| {vehicle} | {r['run'].get('last_time', float('nan')):.1f} | {r['wall']:.0f} | "
                     f"{sum(u['targets_visited'] for u in uavs)}/{sum(u['targets_assigned'] for u in uavs)} | "
                     f"{'-' if slip is None else f'{slip:g}'} |")
    return lines


def figure(scn, rows, path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = scn.n_uavs
    t = scn.targets_enu()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))

    def plan(a, title):
        for z in scn.zones_enu():
            p = z["polygon"]
            a.fill(p[:, 0], p[:, 1], color="red", alpha=0.2)
        a.plot(t[:, 0], t[:, 1], "k^", ms=4, label="targets")
        a.set(xlabel="east m", ylabel="north m", title=title, aspect="equal")

    if n == 1:
        for vehicle, r in rows.items():
            f = r["frame"]
            ax[0].plot(f["uav1_dyn.x"], f["uav1_dyn.y"], label=vehicle)
            ax[1].plot(f["time"], f["uav1_dyn.z"], label=vehicle)
            ax[2].plot(f["time"], f["uav1_dyn.groundspeed"], label=vehicle)
        plan(ax[0], "plan view")
        ax[1].set(xlabel="mission time s", ylabel="height m", title="height")
        ax[2].set(xlabel="mission time s", ylabel="m/s", title="ground speed")
    else:
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for a, (vehicle, r) in zip(ax[:2], rows.items()):
            f = r["frame"]
            for k in range(n):
                a.plot(f[f"uav{k + 1}_dyn.x"], f[f"uav{k + 1}_dyn.y"], lw=1, color=colours[k % 10],
                       label=f"uav{k + 1}")
            plan(a, f"plan view: {vehicle}")
        for vehicle, r in rows.items():
            f = r["frame"]
            style = "-" if vehicle == "sitl" else "--"
            for k in range(n):
                ax[2].step(f["time"], f[f"uav{k + 1}_strat.targets_visited"], style, where="post",
                           color=colours[k % 10], label=f"uav{k + 1} {vehicle}")
        ax[2].set(xlabel="mission time s", ylabel="targets photographed", title="targets over time")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default=str(REPO / "ssp" / "scenarios" / "sitl_zones_1uav_B.yaml"))
    ap.add_argument("--figure", default=None, help="default docs/sitl_fidelity.png (1 UAV) or "
                                                   "docs/sitl_fidelity_<N>uav.png")
    ap.add_argument("--threads", type=int, default=0, help="concurrent doSteps (default: one per UAV)")
    ap.add_argument("--keep", default=None, help="keep the two run folders here")
    a = ap.parse_args(argv)
    os.environ.setdefault("ARDUPILOT_SITL", str(REPO.parent / "shared" / "sitl" / "arducopter"))
    from uavstudy.scenario import load_scenario_yaml
    scn = load_scenario_yaml(a.scenario)
    threads = a.threads or scn.n_uavs
    fig = a.figure or str(REPO / "docs" / ("sitl_fidelity.png" if scn.n_uavs == 1
                                            else f"sitl_fidelity_{scn.n_uavs}uav.png"))
    rows = {}
    with tempfile.TemporaryDirectory(prefix="sitl_fidelity_") as tmp:
        out = Path(a.keep) if a.keep else Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        for vehicle in FIDELITIES:
            rows[vehicle] = fly(scn, vehicle, out, threads)
    print("\n".join(table(scn, rows)))
    figure(scn, rows, fig)
    print(f"figure: {fig}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
