"""Two checkouts of the project, the same benchmarks, alternating: is a refactoring slower?

    python bench/bench_ab.py BEFORE AFTER [--rounds 3] [--what chain,uav4,uav256,campaign]

BEFORE and AFTER are checkouts, each with its own virtual environment in ``.venv`` (``pip install -e .``).
Every round runs each benchmark once in each checkout, the order swapped from one round to the next, so that a
machine whose speed drifts (a shared VM) affects both alike; the table gives every round's figures and the ratio
AFTER / BEFORE of their medians (below 1: AFTER is faster for times, slower for real-time factors).

- ``chain``: ``bench/chain/run_bench.py --only cosim_master``, µs per FMU step of the 10-FMU chain, native C FMUs
  (the step driver in C) and pythonfmu FMUs (the compiled step), API, no supervision;
- ``uav4``: ``bench/bench_uav_scaling.py --sizes 4 --step 0.1``, the one-hour mission's loop real-time factor on
  CPU time;
- ``uav256``: the same with 256 UAVs at 1 s (300 s simulated), loop real-time factor and peak RSS;
- ``campaign``: ``cosim-master campaign ssp/campaigns/paper.yaml`` on 2 workers, the command end to end (wall s).
"""
from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _run(tree: Path, args: list[str], timeout: float = 1800) -> str:
    proc = subprocess.run([str(tree / ".venv" / "bin" / "python"), *args], cwd=tree, capture_output=True,
                          text=True, timeout=timeout)
    if proc.returncode != 0:
        raise SystemExit(f"{tree}: {' '.join(args)} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    return proc.stdout


def chain(tree: Path) -> dict:
    out = _run(tree, ["bench/chain/run_bench.py", "--only", "cosim_master", "--no-write", "--no-install",
                      "--steps", "10000", "--repeats", "3"])
    row = re.search(r"^\| cosim-master \(defaults\) \| ([\d.]+) \| ([\d.]+) \|", out, re.M)
    return {"chain C µs/FMU-step": float(row.group(1)), "chain pythonfmu µs/FMU-step": float(row.group(2))}


def _scaling_row(out: str, n: int) -> list[str]:
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) > 10 and cells[0] == str(n):
            return cells
    raise SystemExit(f"no row for N={n} in:\n{out[-2000:]}")


def uav4(tree: Path) -> dict:
    out = _run(tree, ["bench/bench_uav_scaling.py", "--sizes", "4", "--step", "0.1", "--fine-max", "0",
                      "--no-write"])
    cells = _scaling_row(out, 4)
    return {"4 UAVs 0.1 s: loop RTF on CPU": float(cells[9].rstrip("x"))}


def uav256(tree: Path) -> dict:
    out = _run(tree, ["bench/bench_uav_scaling.py", "--sizes", "256", "--step", "1", "--stop-256", "300",
                      "--no-write"])
    cells = _scaling_row(out, 256)
    return {"256 UAVs 1 s: loop RTF on CPU": float(cells[9].rstrip("x")), "256 UAVs: peak RSS MB": float(cells[10])}


def campaign(tree: Path) -> dict:
    with tempfile.TemporaryDirectory(prefix="bench_ab_") as tmp:
        t0 = time.perf_counter()
        subprocess.run([str(tree / ".venv" / "bin" / "cosim-master"), "campaign", "ssp/campaigns/paper.yaml",
                        "-o", str(Path(tmp) / "c"), "--workers", "2"], cwd=tree, check=True,
                       capture_output=True, timeout=1800)
        return {"paper campaign, CLI, 2 workers: wall s": time.perf_counter() - t0}


BENCHES = {"chain": chain, "uav4": uav4, "uav256": uav256, "campaign": campaign}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--what", default=",".join(BENCHES))
    a = ap.parse_args(argv)
    trees = {"before": a.before.resolve(), "after": a.after.resolve()}
    figures: dict = {}          # (metric) -> {"before": [...], "after": [...]}
    for r in range(a.rounds):
        order = ["before", "after"] if r % 2 == 0 else ["after", "before"]
        for what in a.what.split(","):
            for side in order:
                for metric, value in BENCHES[what](trees[side]).items():
                    figures.setdefault(metric, {"before": [], "after": []})[side].append(value)
                print(f"round {r + 1} {what} {side} done", file=sys.stderr, flush=True)
    print(f"before: {trees['before']}\nafter: {trees['after']}\n")
    print("| measure | before (each round) | after (each round) | after / before (medians) |")
    print("|---|---|---|---|")
    for metric, f in figures.items():
        ratio = statistics.median(f["after"]) / statistics.median(f["before"])
        print(f"| {metric} | {' / '.join(f'{v:.4g}' for v in f['before'])} | "
              f"{' / '.join(f'{v:.4g}' for v in f['after'])} | {ratio:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
