"""Start-up: ``cosim-master run`` of a one-FMU SSP against ``fmpy simulate`` of the same FMU, alternating.

    python bench/bench_startup.py                     # 10 rounds, Reference FMU Dahlquist (FMI 2.0), 100 steps of 0.1 s
    python bench/bench_startup.py --rounds 20 --shared ../shared
    python bench/bench_startup.py --before ../main    # another checkout's cosim-master too, in the same rounds

The FMU is the Modelica Reference FMU Dahlquist (``shared/reference-fmus/fmi2``), run for 10 s in steps of 0.1 s
by every tool; cosim-master runs it as a one-component SSP (written once, before timing, by
``master.ssp.writer.SspBuilder``). Every round runs, in an order rotated from one round to the next so that a machine
whose speed drifts affects all alike:

- ``cosim-master run SSP --stop-time 10 --step 0.1 --record dahlquist.x -o DIR`` (supervised: the default; the
  output fmpy records, an SSP without connections records nothing by default): results.parquet, results.csv,
  run.json;
- the same with ``--no-supervise``;
- ``fmpy simulate FMU --stop-time 10 --output-interval 0.1 --output-file OUT.csv`` (fmpy extracts the FMU into a
  temporary folder, simulates and writes one CSV);
- the same with ``OPENBLAS_NUM_THREADS=1``: NumPy's OpenBLAS threads spin on the other cores after the import, which
  adds CPU time (and instructions under valgrind, by a varying amount) but no work; the ratios are against fmpy as a
  user runs it, and the instruction table adds the ratio against this steadier count.

cosim-master is started as its console script is (``from master.cli import entry; sys.exit(entry())``) with
``PYTHONPATH`` set to this checkout, and with ``--before DIR`` also to that one (the same interpreter and packages:
only ``master`` differs). Each is a fresh process, timed from its start to its exit (wall clock) with the CPU time
of the process and its children (``getrusage``), and their page faults. One warm-up round is not counted (Python's bytecode caches, the
page cache, our FMU cache). Every command runs from bytecode compiled once into the bench's own folder
(``PYTHONPYCACHEPREFIX``; ``PYTHONDONTWRITEBYTECODE`` is removed from the children's environment), as an installed
package does: a checkout with ``__pycache__`` folders and one without (``PYTHONDONTWRITEBYTECODE=1`` on this
machine) would start ~0.1 s apart; ``--environment-bytecode`` keeps the environment's setting. The table gives the median and best
wall time, the median CPU time, and the median over the rounds of each command's wall time divided by fmpy's in
the same round, and the same ratio of CPU time; the load average is printed before and after.
Each command's result is checked: cosim-master's last x against fmpy's.

``--instructions`` adds a measure that the machine's load does not change: each command once more under
valgrind's cachegrind (``--cache-sim=no``, ``PYTHONHASHSEED=0``), the instructions executed by the process that
runs the FMU, from its start to its exit. A forked process's count includes what its parent executed before the
fork, so for the supervised run this is the serial path (interpreter, imports, the fork, the simulation), and
the supervisor's own count is shown beside it (it too includes what was executed before the fork). Each process
ends with its share of the work after the fork (the child simulates, the supervisor imports pyarrow and writes
the files), and the run ends when the later one does: the ratios are of the longer of the two, the run's critical
path in instructions (before 2026-11-29c the child's count alone; the supervisor's was already ~10 M longer).
Needs valgrind; the run takes ~15 s a command.
"""
from __future__ import annotations

import argparse
import csv
import os
import resource
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

from timed_process import run_timed  # bench/ is the script's folder, first on sys.path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

STOP, STEP = 10.0, 0.1


ENTRY = "import sys; from master.cli import entry; sys.exit(entry())"     # what the console script runs
ONE_THREAD = "fmpy simulate, OPENBLAS_NUM_THREADS=1"


def _fmpy() -> list[str]:
    """fmpy's console script beside this interpreter (as a user runs it), else its module."""
    script = Path(sys.executable).parent / "fmpy"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "fmpy.cli"]


def _timed(cmd: list[str], env: dict, cwd: Path) -> tuple[float, float, int]:
    """(wall s, CPU s, page faults) of the command and every process it started (minor and major faults, as
    ``perf stat -e page-faults`` counts them: the kernel's work that the instruction counts below leave out)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc, wall, cpu = run_timed(cmd, env=env, cwd=cwd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    return wall, cpu, (after.ru_minflt - before.ru_minflt) + (after.ru_majflt - before.ru_majflt)


def _last(path: Path, column: str) -> float:
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return float(rows[-1][column])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=10, help="alternating rounds measured (default 10)")
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared",
                    help="the shared folder holding reference-fmus/ (default: ../shared from the checkout)")
    ap.add_argument("--before", type=Path, default=None, metavar="DIR",
                    help="another checkout whose cosim-master is measured too, alternating with this one")
    ap.add_argument("--instructions", action="store_true",
                    help="also count each command's instructions once under valgrind (independent of the load)")
    ap.add_argument("--environment-bytecode", action="store_true",
                    help="keep the environment's bytecode setting (default: every command runs from bytecode "
                         "compiled once into the bench's folder)")
    args = ap.parse_args()
    fmu = args.shared / "reference-fmus" / "fmi2" / "Dahlquist.fmu"
    if not fmu.is_file():
        raise SystemExit(f"{fmu}: not found (give --shared)")

    from master.ssp.writer import SspBuilder
    tmp = Path(tempfile.mkdtemp(prefix="bench-startup-"))
    b = SspBuilder("dahlquist")
    b.add_component("dahlquist", fmu)
    ssp = b.write(tmp / "dahlquist.ssp")
    env = dict(os.environ)
    if not args.environment_bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    run = ["run", str(ssp), "--stop-time", f"{STOP:g}", "--step", f"{STEP:g}", "--record", "dahlquist.x"]
    commands: dict[str, tuple[list[str], dict]] = {}
    for label, tree in (("", ROOT),) + ((("before: ", args.before.resolve()),) if args.before else ()):
        tree_env = dict(env, PYTHONPATH=str(tree))
        cm = [sys.executable, "-c", ENTRY, *run]
        out = tmp / (label.strip(": ") or "this")
        commands[f"{label}cosim-master run (supervised)"] = ([*cm, "-o", str(out / "sup")], tree_env)
        commands[f"{label}cosim-master run --no-supervise"] = ([*cm, "-o", str(out / "nosup"), "--no-supervise"],
                                                               tree_env)
    commands["fmpy simulate"] = ([*_fmpy(), "simulate", str(fmu), "--stop-time", f"{STOP:g}", "--output-interval",
                                  f"{STEP:g}", "--output-file", str(tmp / "fmpy.csv")], env)
    # NumPy's OpenBLAS starts a thread per core at import, which spins on the second core: fmpy's CPU and its
    # instruction count under valgrind (646-765 M across sessions) move with it, its count on one thread does not
    commands[ONE_THREAD] = ([*_fmpy(), "simulate", str(fmu), "--stop-time", f"{STOP:g}", "--output-interval",
                             f"{STEP:g}", "--output-file", str(tmp / "fmpy1.csv")], dict(env, OPENBLAS_NUM_THREADS="1"))
    names = list(commands)
    try:
        _measure(names, commands, tmp, args.rounds, args.environment_bytecode)
        if args.instructions:
            _instructions(names, commands, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)      # the runs' outputs and the compiled bytecode (~9 MB)


def _measure(names: list[str], commands: dict, tmp: Path, rounds: int, environment_bytecode: bool) -> None:
    load_before = os.getloadavg()
    for name in names:                               # warm-up, not counted
        _timed(*commands[name], tmp)
    want = _last(tmp / "fmpy.csv", "x")
    for csv_file in tmp.glob("*/*/results.csv"):
        got = _last(csv_file, "dahlquist.x")
        if got != want:
            raise SystemExit(f"{csv_file}: last x {got!r}, fmpy {want!r}")

    wall: dict[str, list[float]] = {n: [] for n in names}
    cpu: dict[str, list[float]] = {n: [] for n in names}
    faults: dict[str, list[int]] = {n: [] for n in names}
    for r in range(rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            w, c, f = _timed(*commands[name], tmp)
            wall[name].append(w)
            cpu[name].append(c)
            faults[name].append(f)
    load_after = os.getloadavg()
    ref = wall["fmpy simulate"]

    print(f"Dahlquist (FMI 2.0), {int(round(STOP / STEP))} steps of {STEP:g} s; {rounds} alternating rounds; "
          f"load average {' '.join(f'{x:.2f}' for x in load_before)} before, "
          f"{' '.join(f'{x:.2f}' for x in load_after)} after; bytecode: "
          + ("the environment's" if environment_bytecode else "compiled once into the bench's folder"))
    print()
    print("| command | wall median (s) | wall best (s) | CPU median (s) | page faults (median) "
          "| wall / fmpy's (median of rounds) | CPU / fmpy's (median of rounds) |")
    print("|---|---|---|---|---|---|---|")
    ref_cpu = cpu["fmpy simulate"]
    for name in names:
        ratio = statistics.median(w / f for w, f in zip(wall[name], ref))
        cpu_ratio = statistics.median(c / f for c, f in zip(cpu[name], ref_cpu))
        print(f"| {name} | {statistics.median(wall[name]):.3f} | {min(wall[name]):.3f} | "
              f"{statistics.median(cpu[name]):.3f} | {statistics.median(faults[name]):.0f} | {ratio:.2f} | "
              f"{cpu_ratio:.2f} |")


def _instructions(names: list[str], commands: dict, tmp: Path) -> None:
    """Each command once under cachegrind: the instructions of every process it forked (a traced process that
    execs another program, uname or ldconfig, writes no count), as a table."""
    if shutil.which("valgrind") is None:
        raise SystemExit("--instructions needs valgrind")
    print()
    print("Instructions executed (valgrind cachegrind, one run each; millions):")
    print()
    print("| command | the process that runs the FMU | the supervisor | the longer of the two / fmpy's "
          "| / fmpy's on one thread |")
    print("|---|---|---|---|---|")
    counted = {}
    for name in names:
        cmd, env = commands[name]
        folder = Path(tempfile.mkdtemp(prefix="cg-", dir=tmp))
        proc, _, _ = run_timed(["valgrind", "--tool=cachegrind", "--cache-sim=no",
                                f"--cachegrind-out-file={folder}/%p", *cmd],
                               env=dict(env, PYTHONHASHSEED="0"), cwd=tmp)
        if proc.returncode != 0:
            raise SystemExit(f"{name} under valgrind failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
        counts = {int(f.name): _summary(f) for f in folder.iterdir()}
        started = min(counts)           # the process started here (its children's ids come after it)
        forked = [n for pid, n in counts.items() if pid != started]
        counted[name] = (max(forked) if forked else counts[started], counts[started] if forked else None)
    ref, ref_one = counted["fmpy simulate"][0], counted[ONE_THREAD][0]
    for name in names:
        runs, supervisor = counted[name]
        longer = max(runs, supervisor or 0)
        print(f"| {name} | {runs / 1e6:.1f} | {'' if supervisor is None else f'{supervisor / 1e6:.1f}'} | "
              f"{longer / ref:.3f} | {longer / ref_one:.3f} |")


def _summary(path: Path) -> int:
    """The total of a cachegrind output file (its ``summary:`` line)."""
    for line in path.read_text().splitlines():
        if line.startswith("summary:"):
            return int(line.split()[1])
    raise SystemExit(f"{path}: no summary line")


if __name__ == "__main__":
    main()
