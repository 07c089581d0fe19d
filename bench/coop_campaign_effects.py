"""C against B in a campaign of ssp/campaigns/cooperative.yaml: the paired effects, with intervals, per channel
setting (docs/cooperative.md, "Results").

    python bench/coop_campaign_effects.py results/cooperative        # prints markdown tables

Uses the report's estimators as they are: the per-run frame of ``uavstudy.report.tables.uav_frames`` (the run is
the unit; a block is a configuration plus repetition, where a campaign paired on the strategy flies B and C
through the same layout and wind) and ``master.campaign.blocked``: the mean C - B difference over blocks, its t
interval stratified by configuration and the sign-flip permutation p-value.  B ignores the channel axes, so each
C run's twin is the B run of the same block.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

VALUES = [("successes", "successful UAV missions per run"), ("uav_collided", "UAVs removed by UAV-UAV collisions"),
          ("zone_collided", "UAVs removed by zone incursions"), ("photos", "targets photographed per run"),
          ("battery", "mean remaining battery (%)"), ("distance_km", "distance flown per run (km)")]


def effects(r, value: str):
    from master.campaign import blocked as bl
    d = bl.paired_differences(r, value, "strategy", "B", "C", ["cell", "block"])
    return bl.blocked_effect(d["diff"].to_numpy(), strata=d["cell"].to_numpy())


def fmt(e) -> str:
    if e.n_blocks == 0:
        return "n/a"
    return f"{e.estimate:+.2f} [{e.low:+.2f}, {e.high:+.2f}] p={e.p:.3f}"


def main(argv=None) -> int:
    import pandas as pd

    from uavstudy.report.tables import uav_frames
    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0] if args else "results/cooperative")
    df = pd.read_parquet(folder / "results.parquet")
    _, r = uav_frames(df)
    r["range"] = pd.to_numeric(r["comm.range"])
    r["loss"] = pd.to_numeric(r["comm.loss"])
    n_runs = len(r)
    print(f"{folder}: {n_runs} runs ({(r.strategy == 'B').sum()} B, {(r.strategy == 'C').sum()} C), "
          f"{r['block'].nunique()} blocks; C - B per run, mean over blocks [95 % stratified t interval], "
          "sign-flip p\n")
    groups = [("all", r)] + [(f"rules {k}", g) for k, g in r.groupby("rules")] + \
        [(f"{int(n)} UAVs", g) for n, g in r.groupby("n_uavs")] + \
        [(f"range {rg:g} m, loss {ls:g}", g) for (rg, ls), g in r.groupby(["range", "loss"])]
    print("| runs | blocks | " + " | ".join(name for _, name in VALUES) + " |")
    print("|---|---|" + "---|" * len(VALUES))
    for label, g in groups:
        es = [effects(g, v) for v, _ in VALUES]
        print(f"| {label} | {es[0].n_blocks} | " + " | ".join(fmt(e) for e in es) + " |")
    print()
    print("| strategy | UAV missions | successes | UAVs removed by UAV-UAV collisions | by zones |")
    print("|---|---|---|---|---|")
    for s, g in r.groupby("strategy"):
        print(f"| {s} | {int(g['n_uavs'].sum())} | {int(g['successes'].sum())} | {int(g['uav_collided'].sum())} | "
              f"{int(g['zone_collided'].sum())} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
