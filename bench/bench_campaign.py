"""Throughput of the paper campaign (ssp/campaigns/paper.yaml, 2688 runs on 24 layouts) and a profile of one run.
The figures measured before 2026-11-28 are of its 3-layout form, 336 runs: ``--fraction 0.125`` runs that size.

    python bench/bench_campaign.py                      # full campaign on every core + profile
    python bench/bench_campaign.py --fraction 0.25      # every 4th run (stratified), extrapolated
    python bench/bench_campaign.py --profile-only       # just the cProfile of one run
    python bench/bench_campaign.py --phases 48          # CPU per phase of 48 runs in one warm process
    python bench/bench_campaign.py --phases 48 --stop-time 1    # the same, fixed part alone
    python bench/bench_campaign.py --memory 100         # a worker's resident memory after run 1, 10, ..., 100
    python bench/bench_campaign.py --memory 60 --campaign ssp/campaigns/cooperative.yaml    # strategy C
    python bench/bench_campaign.py --alternate /work/main --rounds 3 --fraction 0.125   # this tree vs another

Prints the wall time, runs per minute and per core, the mean run wall time by fleet size, the
extrapolation to the full 336 runs, and the top entries of a cProfile of one warm run (4 UAVs by
default) with the time grouped by layer (UAV model code inside the FMUs, the FMI calls, the master's
step loop, the UAV monitor, the mission outputs incl. map.png, scenario build).

The campaign always runs in a fresh folder (nothing skipped).  The machine's load average is printed
before and after: other processes on the same cores make every number here slower.

Measured on 2026-11-29, second pass (the wind FMUs of removed UAVs step on: 7.6 % of the doStep calls, 5-12 % of a
run's CPU, not changed; the fixed per-run costs; the fork server imports the scenario kind's modules): see
bench/results/campaign_2026-11-29b.md.

Measured on 2026-11-29 (workers: scratch folders, the first run's survivors frozen; the compiled step's text
cached per structure): see bench/results/campaign_2026-11-29.md.

Measured on 2026-11-28, evening (workers forked from a fork server; a worker's memory over many runs,
``--memory``): see bench/results/campaign_2026-11-28b.md.

Measured on 2026-11-27, afternoon (structure parsed and planned once per worker, init shortcuts, the wind's step
in C, the pool's dispatch): 336 runs in 18.4-19.9 s against 22.1-24.0 s before, alternating; see
bench/results/campaign_2026-11-27b.md.

Measured on 2026-11-27 (the fixed part of a run: caches of what runs of one structure share, summary CSVs
without pandas): see bench/results/campaign_2026-11-27.md.

Measured on 2026-11-23 (``rules: paper``, 5 m/s): see bench/results/campaign_2026-11-23.md -- where a
warm worker's run spends its CPU (the step loop ~80 %, FMU instantiation ~8 %, the rest ~10 %), the
worker caches added that day, and the full campaign before/after on a shared machine.

Measured on 2026-11-21 (2 cores; step 0.25 s, stop 1500 s, runs end when the fleet has landed):

* 09:20 UTC, load average 0.6 before: **336 runs in 89.5 s** (225 runs/min, 112.7 runs/min per core), pool
  efficiency 98 %, 0 failed; the CLI right after: 92.7 s.  Target 120 s: met.  Mean warm run by fleet size
  1/2/3/4 UAVs: 0.52/0.47/0.68/0.43 s (4 UAVs under A collide early); one warm 4-UAV B run 0.55 s, of which
  0.06 s is the fixed part (build the SSP from YAML, unpack, plan, instantiate, outputs).
* what got it there from 173 s (the same command earlier that day), each measured on warm single runs:
  the dynamics' 0.01 s sub-steps and the battery's coulomb counting in compiled kernels built into the FMUs
  (bit-identical Python twins, uavsim/kernels.py; 4-UAV run 1.15 -> 0.78 s); the master binding our FMU
  shells' fast accessors (cosim_bind: one attribute getter or one dict update per port; -> ~0.7 s);
  the run's fixed part 0.11 -> 0.06 s (model descriptions from the per-process FMU cache instead of
  re-reading them for every component of the SSP being written, libyaml, record patterns compiled to one
  regular expression, entry points scanned once, the written scenario not parsed again); calm wind steps
  short-cut; recorded-only outputs (lat/lon/alt & co.) read when a row is sampled, and UavDynamics
  computing lat/lon/alt only when read.
* per step of a 1-UAV run (0.25 s step, ~125 us): UAV monitor ~27 us, dynamics ~18 us (of which the 25
  compiled sub-steps are ~2 us; the rest is Python around them), strategy ~15 us, wind ~12 us (windy
  intervals), battery ~11 us, and ~35 us of master transfers and get/set calls over the four FMUs.
  Further gains need fewer Python calls per step (a vectorised fleet model) rather than faster models.
* earlier (06:54 FMUs, before the changes that made runs end when the fleet has landed and skip map.png):
  440 s.
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import shutil
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from master.campaign.execute import execute_run  # noqa: E402
from master.campaign.runner import make_task, run_campaign  # noqa: E402
from master.campaign.spec import load_campaign  # noqa: E402
from phase_timer import PhaseTimer  # noqa: E402

PAPER = ROOT / "ssp" / "campaigns" / "paper.yaml"

LAYERS = [  # (name, substrings of the file path), first match wins
    ("FMU-side get/set shell (uavsim/fmi.py, pythonfmu)", ("uavsim/fmi.py", "pythonfmu")),
    ("UAV model code (uavsim, in the FMUs)", ("uavsim", "/resources/Uav")),
    ("FMI calls (master/fmi)", ("master/fmi",)),
    ("master step loop (algorithms, runner)", ("master/algorithms", "master/runner", "cosim-master step")),
    ("UAV monitor (collisions, zones)", ("uavstudy/monitor", "uavstudy/geometry", "master/monitors")),
    ("mission outputs (summary, trajectory, map.png)", ("uavstudy/outputs", "matplotlib", "PIL")),
    ("scenario build + SSP parse (YAML, SSP, XSD)", ("uavstudy/build", "master/ssp", "uavstudy/scenario",
                                                     "yaml", "lxml", "zipfile")),
    ("recording (parquet)", ("master/recorder", "pyarrow")),
    ("plan/instantiate (master/plan, runtime)", ("master/plan", "master/runtime", "fmpy")),
]


def _layer(filename: str) -> str:
    for name, keys in LAYERS:
        if any(k in filename for k in keys):
            return name
    return "other (numpy, shapely, python)"


def profile_one(n_uavs: int, strategy: str, variant: str, wind: float, top: int = 20) -> None:
    camp = load_campaign(PAPER)
    pick = [r for r in camp.runs if r.params["n_uavs"] == n_uavs and r.params["strategy"] == strategy
            and r.params["variant"] == variant and abs(r.params["wind.probability"] - wind) < 1e-12 and r.rep == 0]
    r = pick[0]
    tmp = Path(tempfile.mkdtemp(prefix="bench-campaign-prof-"))
    try:
        task = make_task(camp, r, tmp)
        t0 = time.perf_counter()
        rec = execute_run(task)           # cold: imports, FMU cache, first map
        cold = time.perf_counter() - t0
        t0 = time.perf_counter()
        rec = execute_run(task)
        warm = time.perf_counter() - t0
        pr = cProfile.Profile()
        pr.enable()
        execute_run(task)
        pr.disable()
        # fixed cost of a run: the same run stopped after 4 steps (build the SSP from YAML, unpack it,
        # plan, instantiate and initialise the FMUs, monitor finish: summary, trajectory, map.png)
        short = dict(task, overrides=dict(task["overrides"], stop_time=4 * task["overrides"]["step"]))
        t0 = time.perf_counter()
        for _ in range(3):
            execute_run(short)
        fixed = (time.perf_counter() - t0) / 3
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    tot = rec["summary"]["total"] if rec.get("summary") else {}
    print(f"\n== profile of one run: {strategy}, {n_uavs} UAV(s), {variant}, wind {wind:g} "
          f"(outcome {rec['outcome']}, simulated {tot.get('end_time')} s, flight time {tot.get('flight_time_s')})")
    print(f"wall: cold {cold:.2f} s (first run in a process), warm {warm:.2f} s (a worker's steady state), "
          f"fixed part {fixed:.2f} s (same run stopped after 4 steps)")
    stats = pstats.Stats(pr)
    total = sum(v[2] for v in stats.stats.values())
    by_layer = defaultdict(float)
    for (fn, _, _), v in stats.stats.items():
        by_layer[_layer(fn)] += v[2]
    print(f"own time by layer (cProfile, total {total:.2f} s incl. profiler overhead):")
    for name, t in sorted(by_layer.items(), key=lambda kv: -kv[1]):
        print(f"  {t:7.2f} s  {100 * t / total:5.1f} %  {name}")
    for key in ("tottime", "cumulative"):
        buf = io.StringIO()
        pstats.Stats(pr, stream=buf).strip_dirs().sort_stats(key).print_stats(top)
        lines = buf.getvalue().splitlines()
        start = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith("ncalls"))
        print(f"\ntop {top} by {key}:")
        print("\n".join(lines[start:start + top + 1]))


PHASES = (  # (phase, what it holds): the parts of one campaign run, as execute_run goes through them
    ("build", "the scenario kind's prepare_run: scenario.yaml, layout, SSD and the run's .ssp archive"),
    ("load", "Execution.setup: open the archive, parse the SSD, plan against the FMUs, settings, observers"),
    ("init", "Execution.initialize: instantiate the FMUs, start values, initialization mode, bind ports"),
    ("loop", "Execution.simulate_until: the master steps until the fleet has landed"),
    ("outputs", "Execution.close: monitors' summary/photos/events, results.parquet, run.json"),
    ("bookkeeping", "the rest of execute_run: run folder, record, summary read, pruning to keep: summary"),
)
# Runtime.instantiate calls bind_samples itself: the table shows instantiate without it
INIT_PARTS = (("instantiate FMUs, ports", "Runtime", "instantiate"), ("bind sampled reads", "Runtime", "bind_samples"),
              ("initialization mode", "Runtime", "initialize"))


def phase_breakdown(n_runs: int, stop_time: float | None = None) -> None:
    """CPU time per phase of ``n_runs`` runs of the campaign (every k-th, so every fleet size and variant
    appears) executed one after another in this process, as a warm worker runs them; ``stop_time``: each run
    stopped then (e.g. 1 s: the fixed part alone)."""
    import master.execution as ex
    import master.runtime as rtm
    from master.scenario_kinds import SCENARIO_KINDS
    camp = load_campaign(PAPER)
    kind_cls = type(SCENARIO_KINDS.get(camp.kind))
    timer = PhaseTimer()
    spent, clock = timer.spent, timer.clock
    for owner, name, label in ((kind_cls, "prepare_run", "build"), (ex.Execution, "setup", "load"),
                               (ex.Execution, "simulate_until", "loop"), (ex.Execution, "close", "outputs")):
        timer.wrap(owner, name, label)
    for label, _, name in INIT_PARTS:
        timer.wrap(rtm.Runtime, name, f"init: {label}")
    timer.wrap_initialize(ex.Execution, "init")     # setup counts as load, the rest as init
    every = max(1, len(camp.runs) // n_runs)
    runs = [camp.runs[i * every] for i in range(n_runs)]
    tmp = Path(tempfile.mkdtemp(prefix="bench-campaign-phases-"))
    try:
        execute_run(make_task(camp, camp.runs[1], tmp))       # the worker's cold start is not a phase of a run
        spent.clear()
        total_cpu, steps = 0.0, 0
        t_wall = time.perf_counter()
        for r in runs:
            task = make_task(camp, r, tmp)
            if stop_time is not None:
                task["overrides"] = dict(task["overrides"], stop_time=stop_time)
            c0 = clock()
            rec = execute_run(task)
            total_cpu += clock() - c0
            steps += round((rec.get("last_time") or 0.0) / rec.get("step_size", 1.0))
        wall = time.perf_counter() - t_wall
    finally:
        timer.restore()
        shutil.rmtree(tmp, ignore_errors=True)
    spent["bookkeeping"] = total_cpu - sum(spent[p] for p, _ in PHASES if p != "bookkeeping")
    spent["init: instantiate FMUs, ports"] -= spent["init: bind sampled reads"]
    cut = f", stopped at {stop_time:g} s" if stop_time is not None else ""
    print(f"\n== phases of {n_runs} runs (every {every}th of {camp.name}{cut}) in one warm process: "
          f"{total_cpu / n_runs * 1000:.0f} ms CPU per run ({wall / n_runs * 1000:.0f} ms wall), "
          f"{steps / n_runs:.0f} master steps per run; load average {os.getloadavg()[0]:.2f}")
    print(f"{'phase':<26} {'ms CPU/run':>10} {'share':>6}  what")
    for p, what in PHASES:
        print(f"{p:<26} {spent[p] / n_runs * 1000:10.1f} {100 * spent[p] / total_cpu:5.1f}%  {what}")
        if p == "init":
            for label, _, _ in INIT_PARTS:
                v = spent[f"init: {label}"]
                print(f"{'  ' + label:<26} {v / n_runs * 1000:10.1f} {100 * v / total_cpu:5.1f}%")
    fixed = total_cpu - spent["loop"]
    print(f"fixed part (all but the loop): {fixed / n_runs * 1000:.0f} ms CPU per run; loop "
          f"{spent['loop'] / max(1, steps) * 1e6:.0f} us CPU per master step")


def _rss_mb() -> tuple[float, float]:
    """(resident, peak resident) of this process in MB, from /proc/self/status (VmRSS, VmHWM)."""
    got = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(("VmRSS:", "VmHWM:")):
            key, value = line.split(":", 1)
            got[key] = int(value.split()[0]) / 1024
    return got.get("VmRSS", float("nan")), got.get("VmHWM", float("nan"))


def memory_growth(n_runs: int, campaign: Path, report_at=(1, 10, 25, 50, 100, 200, 400)) -> None:
    """A worker's memory over ``n_runs`` runs of ``campaign`` (every k-th run, so that every fleet size and
    variant comes), run one after another in this process as a pool worker runs them (``execute_run``), with the
    garbage collected before each reading: a leak shows as growth per run after the first ten (the FMU cache, the
    structures kept per SSD and the first imports fill the first runs).  Strategy C's comm monitor kept every
    finished run alive (~8 MB a run in the 4160-run cooperative campaign until the kernel killed the worker):
    ``--memory 60 --campaign ssp/campaigns/cooperative.yaml`` shows such growth."""
    import gc
    camp = load_campaign(campaign)
    every = max(1, len(camp.runs) // n_runs)
    runs = [camp.runs[(i * every) % len(camp.runs)] for i in range(n_runs)]
    tmp = Path(tempfile.mkdtemp(prefix="bench-campaign-memory-"))
    rows = []
    try:
        rss0, _ = _rss_mb()
        for k, r in enumerate(runs, 1):
            rec = execute_run(make_task(camp, r, tmp))
            if rec["outcome"] != "completed":
                print(f"run {r.run_id} {rec['outcome']}: {rec.get('error')}")
            if k in report_at or k == n_runs:
                gc.collect()
                rows.append((k, *_rss_mb()))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"\n== a worker's memory over {n_runs} runs of {camp.name} (every {every}th run, in one process); "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"before the first run: {rss0:.0f} MB resident")
    print(f"{'after run':>10} {'resident MB':>12} {'peak MB':>9}")
    for k, rss, peak in rows:
        print(f"{k:>10} {rss:>12.1f} {peak:>9.1f}")
    tenth = next(((k, rss) for k, rss, _ in rows if k == 10), None)
    if tenth and n_runs > 10:
        growth = (rows[-1][1] - tenth[1]) / (n_runs - 10)
        print(f"growth from run 10 to run {n_runs}: {growth * 1024:.0f} kB per run")


def run_bench(fraction: float, workers: int | None, output: Path | None, keep_output: bool) -> None:
    camp = load_campaign(PAPER)
    every = max(1, round(1 / fraction))
    out = output or Path(tempfile.mkdtemp(prefix="bench-campaign-"))
    if out.exists():
        shutil.rmtree(out)
    n_workers = workers or len(os.sched_getaffinity(0))
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    s = run_campaign(PAPER, output=out, workers=n_workers, progress=True,
                     run_filter=(lambda r: r.index % every == 0) if every > 1 else None)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()[0]
    import pandas as pd
    df = pd.read_parquet(out / "results.parquet")
    runs = df.drop_duplicates("run_id")
    print(f"\n== campaign {camp.name}: {s.ran_now} of {len(camp.runs)} runs (every {every}), {n_workers} worker(s), "
          f"{len(os.sched_getaffinity(0))} core(s); load average {load0:.2f} before, {load1:.2f} after")
    print(s.describe())
    rate = s.ran_now / wall * 60
    print(f"wall {wall:.1f} s (incl. worker start and table), {rate:.1f} runs/min, "
          f"{rate / n_workers:.1f} runs/min per core")
    print(f"sum of run wall times {runs['wall_time_s'].sum():.1f} s -> pool efficiency "
          f"{runs['wall_time_s'].sum() / (wall * n_workers) * 100:.0f} %")
    est = wall * len(camp.runs) / max(1, s.ran_now)
    print(f"full {len(camp.runs)} runs on {n_workers} core(s): {est:.0f} s = {est / 60:.1f} min "
          f"({'measured' if every == 1 else 'extrapolated'}); target 120 s")
    print("\nmean run wall time [s] by fleet size (warm workers):")
    g = runs.groupby(["n_uavs", "strategy", "variant"])["wall_time_s"].mean().unstack(["strategy", "variant"])
    print(g.round(2).to_string())
    print(runs.groupby("n_uavs")["wall_time_s"].agg(["mean", "min", "max", "count"]).round(2).to_string())
    if not keep_output and output is None:
        shutil.rmtree(out, ignore_errors=True)
    else:
        print(f"campaign folder kept: {out}")


def alternate(other: Path, rounds: int, fraction: float, workers: int) -> None:
    """This tree and ``other`` (a checkout of the project) alternating, the order swapped each round: the campaign
    bench (``--fraction``, ``--workers``, no profile) as a child process of this interpreter with PYTHONPATH set to
    each tree, timed end to end (interpreter start to exit) with the CPU of the whole process tree (the fork server
    and the workers are reaped), and the campaign's own wall time as the bench prints it."""
    import re
    from timed_process import run_timed
    trees = {"this": ROOT, "other": other.resolve()}
    cmd = ["bench/bench_campaign.py", "--fraction", str(fraction), "--workers", str(workers), "--no-profile"]
    rows = []
    for r in range(rounds):
        for side in (("other", "this") if r % 2 == 0 else ("this", "other")):
            tree = trees[side]
            env = dict(os.environ, PYTHONPATH=str(tree))
            load = os.getloadavg()[0]
            proc, wall, cpu = run_timed([sys.executable, *cmd], cwd=tree, env=env, timeout=1800)
            if proc.returncode != 0:
                raise SystemExit(f"{tree}: {' '.join(cmd)} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
            m = re.search(r"^wall ([\d.]+) s", proc.stdout, re.M)
            rows.append((r + 1, side, load, os.getloadavg()[0], float(m.group(1)) if m else float("nan"), wall, cpu))
    print(f"\n== the paper campaign, every {round(1 / fraction)}th run, {workers} workers: this tree {trees['this']} "
          f"against {trees['other']}, alternating ({len(os.sched_getaffinity(0))} cores)")
    print("| round | tree | load before | load after | campaign wall s | process wall s | CPU s (whole tree) |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for r, side, l0, l1, cw, wall, cpu in rows:
        print(f"| {r} | {side} | {l0:.2f} | {l1:.2f} | {cw:.1f} | {wall:.1f} | {cpu:.1f} |")
    for what, k in (("campaign wall", 4), ("process wall", 5), ("CPU", 6)):
        med = {side: statistics.median(row[k] for row in rows if row[1] == side) for side in trees}
        print(f"median {what}: this {med['this']:.1f} s, other {med['other']:.1f} s, this/other "
              f"{med['this'] / med['other']:.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fraction", type=float, default=1.0, help="run every round(1/F)-th run (default 1: all 2688; 0.125: the 336 runs of the earlier figures)")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--output", type=Path, default=None, help="campaign folder (default: a temporary one)")
    ap.add_argument("--keep-output", action="store_true")
    ap.add_argument("--profile-only", action="store_true")
    ap.add_argument("--phases", type=int, default=0, metavar="N",
                    help="CPU time per phase (build, load, init, loop, outputs, bookkeeping) of N runs in one "
                         "process, then exit")
    ap.add_argument("--stop-time", type=float, default=None, help="with --phases: stop each run then (1: the fixed "
                    "part alone)")
    ap.add_argument("--memory", type=int, default=0, metavar="N",
                    help="a worker's resident memory after run 1, 10, ..., N of --campaign in one process, then exit")
    ap.add_argument("--campaign", type=Path, default=PAPER, help="with --memory: the campaign file (default paper)")
    ap.add_argument("--no-profile", action="store_true")
    ap.add_argument("--alternate", type=Path, default=None, metavar="TREE",
                    help="this tree against TREE (another checkout, e.g. /work/main), alternating --rounds times: "
                         "wall and whole-tree CPU of the bench at --fraction on --workers (default 2), then exit")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--profile-run", default="4,B,free,0.15",
                    help="n_uavs,strategy,variant,wind of the profiled run (default 4,B,free,0.15)")
    args = ap.parse_args()
    if args.alternate:
        alternate(args.alternate, args.rounds, args.fraction, args.workers or 2)
        return
    if args.phases:
        phase_breakdown(args.phases, args.stop_time)
        return
    if args.memory:
        memory_growth(args.memory, args.campaign)
        return
    if not args.profile_only:
        run_bench(args.fraction, args.workers, args.output, args.keep_output)
    if not args.no_profile:
        n, s, v, w = args.profile_run.split(",")
        profile_one(int(n), s, v, float(w))


if __name__ == "__main__":
    main()
