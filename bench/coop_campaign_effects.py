"""C against B in a campaign of ssp/campaigns/cooperative.yaml: the paired effects with layout-level intervals,
overall, per rule set, fleet size, and per channel range x loss cell (docs/cooperative.md, "Results").

    python bench/coop_campaign_effects.py results/cooperative        # prints markdown tables

Uses the report's estimators as they are (``uavstudy.report.cooperative``): every C run against the B run of the
same layout, rule set, fleet and wind, the differences averaged per layout, then the mean over layouts with its
t interval (df = layouts - 1).  The report (``cosim-master report``) has the same numbers per range and per loss
level; this script adds the finer range x loss cells.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    import pandas as pd

    from uavstudy.report import cooperative as co
    from uavstudy.report.tables import uav_frames
    from uavstudy.report.text import ci_text
    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0] if args else "results/cooperative")
    df = pd.read_parquet(folder / "results.parquet")
    _, r = uav_frames(df)
    r = co.with_run_values(r, df)
    print(f"{folder}: {len(r)} runs ({(r.strategy == 'B').sum()} B, {(r.strategy == 'C').sum()} C), "
          f"{r['layout'].nunique()} layouts; C - B per run, mean over layouts [95 % t interval], p\n")
    c = r["strategy"] == "C"
    r["_cell"] = "all"
    r.loc[c, "_cell"] = [f"range {a:g} m, loss {b:g}" for a, b in zip(r.loc[c, "range"], r.loc[c, "loss"])]
    groups = [("all", r)] + [(f"{k} rules", g) for k, g in r.groupby("rules")] + \
        [(f"{int(n)} UAVs", g) for n, g in r.groupby("n_uavs")]
    print("| runs | " + " | ".join(label for _, label, _ in co.METRICS) + " |")
    print("|---|" + "---|" * len(co.METRICS))
    for label, g in groups:
        cells = [ci_text(co.effects_by(g, col)["all"], 2, show_n=False) for col, _, _ in co.METRICS]
        print(f"| {label} | " + " | ".join(cells) + " |")
    cells = {col: co.effects_by(r, col, "_cell") for col, _, _ in co.METRICS}
    def numeric(k):   # "range 15 m, loss 0.5" -> (15.0, 0.5)
        return tuple(float(w.rstrip(",")) for w in k.split() if w.rstrip(",").replace(".", "").isdigit())
    for key in sorted((k for k in cells["successes"] if k != "all"), key=numeric):
        print(f"| {key} | " + " | ".join(ci_text(cells[col][key], 2, show_n=False) for col, _, _ in co.METRICS)
              + " |")
    print()
    print("| strategy | UAV missions | successes | UAVs removed by UAV-UAV collisions | by zones |")
    print("|---|---|---|---|---|")
    for s, g in r.groupby("strategy"):
        print(f"| {s} | {int(g['n_uavs'].sum())} | {int(g['successes'].sum())} | {int(g['uav_collided'].sum())} | "
              f"{int(g['zone_collided'].sum())} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
