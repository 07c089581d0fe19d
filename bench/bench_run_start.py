"""CPU time of the parts of a run's start (``Execution.initialize``) in a warm campaign worker.

    python bench/bench_run_start.py                 # 20 runs of the paper campaign, stopped at 1 s, 3 rounds
    python bench/bench_run_start.py --no-gc         # the same with the cyclic garbage collector off (its pauses
                                                    # land in whichever part allocates when one is due)

Prints ms of CPU per run for Execution.initialize as a whole and for its parts (a part called inside another,
e.g. make_slave inside Runtime.instantiate, is counted in both). bench_campaign.py --phases gives the phases of
whole runs; this script splits the "init" phase further.

Measured on 2026-11-27 (shared machine, load 5.5-6, --no-gc, two alternating rounds; before = cda6aeb, after = the
"init" branch): Execution.initialize 14.4 / 12.4 -> 11.5 / 9.2 ms; Runtime.instantiate 3.3 / 2.9 -> 2.7 / 2.2
(in-process ports without ctypes pointers, slavemodule.txt read once); algorithm.prepare 3.1 / 2.8 -> 0.9 / 0.8
(the step's code cached by its source; the getters now bound in initialization); start values 1.2 / 1.2 ->
0.4 / 0.35 (one update per slave and type); Runtime.__init__ 0.8 -> 0.4; _bind_ports 0.8 -> 0.4. What remains is
mostly the FMUs' own exit_initialization_mode (~2 ms; UavStrategy ~0.45 ms a call: a ZoneMap built for zones no
free map has, the mission's thousand indexed parameters decoded) and their constructors (~1.3 ms).
"""
from __future__ import annotations

import argparse
import gc
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import master.algorithms.base as algorithms  # noqa: E402
import master.execution as execution  # noqa: E402
import master.runtime as runtime  # noqa: E402
from master.campaign.execute import execute_run  # noqa: E402
from master.campaign.runner import make_task  # noqa: E402
from master.campaign.spec import load_campaign  # noqa: E402
from phase_timer import PhaseTimer  # noqa: E402

PAPER = ROOT / "ssp" / "campaigns" / "paper.yaml"
PARTS = [(runtime.Runtime, name, f"Runtime.{name}") for name in
         ("__init__", "instantiate", "_bind_ports", "bind_samples", "apply_start_values", "initialize")]
PARTS += [(runtime, "make_slave", "make_slave"), (algorithms.Algorithm, "prepare", "algorithm.prepare"),
          (execution, "algebraic_loops", "algebraic_loops"), (execution, "gauss_seidel_order", "gauss_seidel_order")]


def measure(n_runs: int, rounds: int, stop_time: float, no_gc: bool) -> dict:
    timer = PhaseTimer()
    spent = timer.spent
    for owner, name, label in PARTS:
        timer.wrap(owner, name, label)
    timer.wrap_initialize(execution.Execution, "Execution.initialize")
    camp = load_campaign(PAPER)
    every = max(1, len(camp.runs) // n_runs)
    runs = [camp.runs[i * every] for i in range(n_runs)] * rounds
    tmp = Path(tempfile.mkdtemp(prefix="bench-run-start-"))
    try:
        execute_run(make_task(camp, camp.runs[1], tmp))      # the worker's cold start
        spent.clear()
        if no_gc:
            gc.collect()
            gc.disable()
        for r in runs:
            task = make_task(camp, r, tmp)
            task["overrides"] = dict(task["overrides"], stop_time=stop_time)
            rec = execute_run(task)
            if rec.get("outcome") != "completed":
                raise SystemExit(f"run {r.index} did not complete: {rec.get('error')}")
    finally:
        gc.enable()
        timer.restore()
        shutil.rmtree(tmp, ignore_errors=True)
    return {k: v / len(runs) * 1000 for k, v in spent.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="every k-th run of the campaign, this many (default 20)")
    ap.add_argument("--rounds", type=int, default=3, help="each run this many times (default 3)")
    ap.add_argument("--stop-time", type=float, default=1.0)
    ap.add_argument("--no-gc", action="store_true", help="the cyclic garbage collector off while measuring")
    args = ap.parse_args()
    ms = measure(args.runs, args.rounds, args.stop_time, args.no_gc)
    print(f"{'part of the run start':<26} {'ms CPU/run':>10}   ({args.runs} runs x {args.rounds}, stopped at "
          f"{args.stop_time:g} s, gc {'off' if args.no_gc else 'on'})")
    for label, v in sorted(ms.items(), key=lambda kv: -kv[1]):
        print(f"{label:<26} {v:10.2f}")


if __name__ == "__main__":
    main()
