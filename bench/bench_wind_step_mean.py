"""Cost of the wind FMU's per-step work, uavsim.wind.Wind.mean_over (the step mean the UavWind FMU publishes).

    python bench/bench_wind_step_mean.py                      # this checkout's fmu_sources/uavsim
    python bench/bench_wind_step_mean.py --uavsim OTHER_DIR   # another copy (a folder holding uavsim/), e.g.
                                                              # `git worktree add /tmp/base <commit>` + OTHER_DIR
                                                              # = /tmp/base/fmu_sources, for a before/after table

For each wind setting and master step it steps one wind through an hour (one call per step, as one UAV's wind FMU
does) and prints the microseconds per call (best of --repeat, wall clock) and the share of windy steps.  The
campaign (ssp/campaigns/paper.yaml) uses probabilities 0 ... 0.15 with 10 s episodes and 0.25 s steps; the scaling
benchmark has no wind.  A loaded machine makes every number slower, not the ratios.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SETTINGS = [  # label, WindParams fields
    ("no wind (p 0)", dict(probability=0.0)),
    ("p 0.15, T 10 s (campaign's windiest)", dict(probability=0.15)),
    ("p 0.15, T 1 s, gusts", dict(probability=0.15, decision_interval=1.0, duration=1.0, ramp=0.25,
                                             gusts=True)),
    ("p 0.15, T 10 s, gusts + turbulence", dict(probability=0.15, gusts=True, turbulence=True)),
    ("p 1, T 10 s (always windy)", dict(probability=1.0)),
]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uavsim", type=Path, default=ROOT / "fmu_sources", help="folder holding the uavsim package")
    ap.add_argument("--steps", default="0.1,0.25", help="master step sizes (s), comma-separated")
    ap.add_argument("--seconds", type=float, default=3600.0, help="simulated time per setting")
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(a.uavsim.resolve()))
    from uavsim.wind import Wind, WindParams
    print(f"uavsim from {a.uavsim.resolve()}\n")
    print("| wind | step s | calls | windy steps | us per call |")
    print("|---|---|---|---|---|")
    for label, kw in SETTINGS:
        for h in (float(x) for x in a.steps.split(",")):
            n = int(round(a.seconds / h))
            best, windy = float("inf"), 0
            for _ in range(a.repeat):
                w = Wind(WindParams(seed=5, **kw))
                mean = w.mean_over
                t0 = time.perf_counter()
                for i in range(n):
                    mean(i * h, (i + 1) * h)
                best = min(best, time.perf_counter() - t0)
            w = Wind(WindParams(seed=5, **kw))
            windy = sum(1 for i in range(n) if w.mean_over(i * h, (i + 1) * h)[3] > 0)
            print(f"| {label} | {h:g} | {n} | {100.0 * windy / n:.1f} % | {best / n * 1e6:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
