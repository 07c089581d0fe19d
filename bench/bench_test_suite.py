"""CPU and wall time of the README's test command, and the test files that cost the most.

    python bench/bench_test_suite.py                      # the README's command (python -m pytest -q), whole suite
    python bench/bench_test_suite.py --per-dir            # one pytest per test directory: exact CPU per directory
    python bench/bench_test_suite.py --per-dir tests/master tests/master/fmi   # only these directories' own files
    python bench/bench_test_suite.py tests/master/fmi     # a part of the suite (paths are given to pytest)
    python bench/bench_test_suite.py --repo /path/to/other/checkout   # e.g. main, to compare before and after

CPU is ``resource.getrusage(RUSAGE_CHILDREN)`` taken around each pytest process: user and system time of pytest
and of every process it started and waited for (CLI subprocesses, supervised run children, campaign workers),
as ``/usr/bin/time`` counts them. A process nobody waits for (a daemon left behind) is not counted.

The per-file table adds up the CPU of each test, measured inside pytest by ``bench/pytest_cpu_per_test.py``
(user + system of pytest and of the children reaped during the test, from its setup to its teardown; a
module-scoped fixture is charged to the first test that needs it). What pytest spends outside tests (start,
collection) is the difference to the total. Wall seconds per file (pytest's ``--durations``) are shown beside it.

The command is run with ``--durations=0 -p no:cacheprovider -p pytest_cpu_per_test`` added (they only report,
or keep the checkout clean); none changes what runs.
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DURATION = re.compile(r"^\s*([0-9.]+)s (setup|call|teardown)\s+(\S+?)(?:::(\S.*))?$")
SUMMARY = re.compile(r"^=*\s*(.*\b(?:passed|failed|error|errors|skipped)\b.*?) in [0-9.]+s")


def _children_cpu() -> tuple[float, float]:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime, r.ru_stime


def run_pytest(repo: Path, python: str, paths: list[str], extra: list[str], keep_cpu: Path | None = None) -> dict:
    """One pytest process over ``paths``: CPU of it and its waited-for descendants, wall, per-file durations."""
    cmd = [python, "-m", "pytest", "-q", "--durations=0", "-p", "no:cacheprovider", "-p", "pytest_cpu_per_test",
           *extra, *paths]
    with tempfile.TemporaryDirectory(prefix="bench-test-suite-") as tmp:
        cpu_file = Path(tmp) / "cpu.tsv"
        env = dict(os.environ, COSIM_TEST_CPU_FILE=str(cpu_file),
                   PYTHONPATH=os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")])))
        u0, s0 = _children_cpu()
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=repo, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - t0
        u1, s1 = _children_cpu()
        cpu_lines = cpu_file.read_text().splitlines() if cpu_file.exists() else []
    if keep_cpu is not None and cpu_lines:
        with open(keep_cpu, "a", encoding="utf-8") as f:
            f.writelines(line + "\n" for line in cpu_lines)
    cpu_per_file: dict[str, float] = defaultdict(float)
    for line in cpu_lines:
        seconds, nodeid = line.split("\t", 1)
        cpu_per_file[nodeid.split("::", 1)[0]] += float(seconds)
    per_file: dict[str, float] = defaultdict(float)
    summary = ""
    for line in proc.stdout.splitlines():
        m = DURATION.match(line)
        if m:
            per_file[m.group(3)] += float(m.group(1))
            continue
        m = SUMMARY.match(line)
        if m:
            summary = m.group(1)
    return {"paths": paths, "user": u1 - u0, "sys": s1 - s0, "wall": wall, "rc": proc.returncode,
            "per_file": dict(per_file), "cpu_per_file": dict(cpu_per_file), "summary": summary, "tail": proc.stdout.splitlines()[-5:],
            # pytest's short summary: which tests failed, so that a figure taken from a failing suite says why
            "failures": [line for line in proc.stdout.splitlines() if line.startswith(("FAILED ", "ERROR "))]}


def test_directories(repo: Path, only: list[str] | None = None) -> list[list[str]]:
    """Every directory holding test files (or those of ``only``), the files directly in it as one unit (not its
    sub-directories)."""
    wanted = {(repo / d).resolve() for d in only} if only else None
    units = []
    for d in sorted({p.parent for p in (repo / "tests").rglob("test_*.py")}):
        if wanted is not None and d.resolve() not in wanted:
            continue
        files = sorted(str(p.relative_to(repo)) for p in d.glob("test_*.py"))
        if files:
            units.append(files)
    return units


def _label(paths: list[str]) -> str:
    return str(Path(paths[0]).parent) + "/" if len(paths) > 1 or paths[0].endswith(".py") else paths[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="*", help="what pytest runs (default: the README's command, every test); with "
                    "--per-dir, the directories to measure (each one's own files)")
    ap.add_argument("--repo", type=Path, default=ROOT, help="the checkout to measure (default: this one)")
    ap.add_argument("--python", default=None, help="interpreter (default: the checkout's .venv, else this one)")
    ap.add_argument("--per-dir", action="store_true", help="one pytest process per test directory")
    ap.add_argument("--top", type=int, default=20, help="files in the per-file table")
    ap.add_argument("--pytest-args", default="", help="more pytest options, one string (e.g. '-x')")
    ap.add_argument("--cpu-per-test", type=Path, default=None,
                    help="append every test's CPU (CPU_S<TAB>nodeid) to this file, for bench/pytest_cpu_per_test.py's "
                         "comparisons")
    args = ap.parse_args(argv)

    repo = args.repo.resolve()
    python = args.python or (str(repo / ".venv" / "bin" / "python") if (repo / ".venv" / "bin" / "python").exists()
                             else sys.executable)
    extra = args.pytest_args.split()
    units = test_directories(repo, args.paths) if args.per_dir else [args.paths]

    load0 = os.getloadavg()
    results = []
    for paths in units:
        r = run_pytest(repo, python, paths, extra, args.cpu_per_test)
        results.append(r)
        if args.per_dir:
            print(f"  {_label(paths):45s} {r['user']:7.1f} user {r['sys']:6.1f} sys {r['wall']:7.1f} wall"
                  f"  {r['summary']}", flush=True)
    load1 = os.getloadavg()

    user = sum(r["user"] for r in results)
    sys_ = sum(r["sys"] for r in results)
    wall = sum(r["wall"] for r in results)
    print(f"\nrepo {repo}")
    print(f"command: {python} -m pytest -q {'' if args.per_dir else ' '.join(args.paths)}"
          + (" (one process per directory)" if args.per_dir else ""))
    print(f"load average before {load0[0]:.1f}, after {load1[0]:.1f} (1 min)\n")
    print("| user CPU s | system CPU s | user+system s | wall s | exit |")
    print("|---:|---:|---:|---:|---|")
    print(f"| {user:.1f} | {sys_:.1f} | {user + sys_:.1f} | {wall:.1f} | "
          f"{','.join(sorted({str(r['rc']) for r in results}))} |")
    for r in results:
        if not args.per_dir:
            print(f"\npytest: {r['summary'] or ' / '.join(r['tail'])}")
            for line in r["failures"]:
                print(f"    {line}")

    cpu: dict[str, float] = defaultdict(float)
    walls: dict[str, float] = defaultdict(float)
    for r in results:
        for f, v in r["cpu_per_file"].items():
            cpu[f] += v
        for f, v in r["per_file"].items():
            walls[f] += v
    if cpu:
        in_tests = sum(cpu.values())
        print(f"\nTop {args.top} test files by CPU (user+system s of their tests, children included); all tests "
              f"{in_tests:.1f} s, pytest outside tests {user + sys_ - in_tests:.1f} s")
        print("| file | CPU s | share | wall s |")
        print("|---|---:|---:|---:|")
        for f, v in sorted(cpu.items(), key=lambda kv: -kv[1])[:args.top]:
            print(f"| {f} | {v:.1f} | {100 * v / (user + sys_):.1f} % | {walls.get(f, 0.0):.1f} |")
    return 0 if all(r["rc"] in (0,) for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
