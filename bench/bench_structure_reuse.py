"""CPU time of a campaign run's fixed "build" and "load" phases as one worker sees them (consecutive runs of the
paper campaign, every ``--stride``-th: a 2-worker pool hands each worker about every other run), i.e. with the
repeated structures that a worker reads again (``reuse_structure``), next to bench_campaign.py's ``--phases``
(which spreads its runs over the whole grid, so it sees few repeats).

    python bench/bench_structure_reuse.py --runs 42 --stride 2 --rounds 3      # from the checkout measured

Runs with stop time 1 s (the loop is not what is measured). Prints ms CPU (of the running thread) per run of each
phase and round.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

from phase_timer import PhaseTimer

ROOT = Path.cwd()      # the checkout whose campaign and code are measured (run it from there)
PAPER = ROOT / "ssp" / "campaigns" / "paper.yaml"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=42)
    ap.add_argument("--stride", type=int, default=2)
    ap.add_argument("--start", type=int, default=0, help="first run index")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    import master.execution as ex
    from master.campaign.execute import execute_run
    from master.campaign.runner import make_task
    from master.campaign.spec import load_campaign
    from master.scenario_kinds import SCENARIO_KINDS
    camp = load_campaign(PAPER)
    kind_cls = type(SCENARIO_KINDS.get(camp.kind))
    # this thread only: a finished run's background threads (sinks) are not build or load
    timer = PhaseTimer(time.thread_time)
    spent = timer.spent
    timer.wrap(kind_cls, "prepare_run", "build")
    timer.wrap(ex.Execution, "setup", "load")
    runs = camp.runs[args.start::args.stride][:args.runs]
    tmp = Path(tempfile.mkdtemp(prefix="bench-structure-"))
    print(f"{len(runs)} runs (every {args.stride}th from {args.start}), stop time 1 s; load average "
          f"{os.getloadavg()[0]:.2f}; code {Path(ex.__file__).resolve().parents[1]}")
    print(f"{'round':>5} {'build ms':>9} {'load ms':>8} {'build+load':>10}")
    try:
        for rnd in range(args.rounds):
            # each round a fresh worker's view: the first run of each structure reads it, the later ones reuse it
            for mod in ("master.ssp.parser", "master.plan.reuse"):
                m = sys.modules.get(mod)
                for cache in ("_STRUCTURES", "_PLANS", "_PARAMETER_SETS"):
                    if m is not None and hasattr(m, cache):
                        getattr(m, cache).clear()
            spent.clear()
            for r in runs:
                task = make_task(camp, r, tmp)
                task["overrides"] = dict(task["overrides"], stop_time=1.0)
                rec = execute_run(task)
                if rec["outcome"] != "completed":
                    raise SystemExit(f"run {r.index}: {rec['outcome']} {rec.get('error')}")
            n = len(runs)
            b, lo = spent["build"] / n * 1000, spent["load"] / n * 1000
            print(f"{rnd:>5} {b:9.2f} {lo:8.2f} {b + lo:10.2f}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
