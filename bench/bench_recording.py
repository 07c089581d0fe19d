"""What recording every variable costs: a run of a stand-in for the 20-sim ControlledTemperature cross-check FMU
(bench/recording: 120 variables, cheap steps) over 200,000 steps of 1e-4 s, recording one variable, all variables
without CSV, and all variables with CSV (the default outputs), as ``cosim-master run`` does it (supervised unless
``--no-supervise``). The configurations run alternately, ``--rounds`` times; the table gives the median wall time
and CPU time (user + system of the command and its child), and each against the one-variable run of the same
FMU, with the load average before and after.

Two stand-ins (``--workload``, both by default): ``harsh``, 120 Reals of their own, 110 changing in every step
with full-precision digits (the first session's bench, the harder case), and ``20sim``, the original's
variable make-up (most variables aliases of a few quantities, 19 parameters, 2 Booleans; build.py).

    python bench/bench_recording.py [--rounds 5] [--steps 200000] [--workload harsh|20sim|both]
                                    [--no-supervise] [--pure] [--parts] [--before CLI]

``--parts`` measures each part of the recording (block tables, CSV text, CSV sink, Parquet sink) on the last
run's table in this process. ``--pure`` adds the all-variables run with ``COSIM_MASTER_PURE_PYTHON=1`` (the Python CSV writer, the
reference); ``--before CLI`` adds every configuration run by another checkout's ``cosim-master`` (e.g.
``/work/main/.venv/bin/cosim-master``), in the same rounds.
After the runs it checks what the issue asks: results.csv holds the same bytes as the Python reference
(``master.sinks.csv_text.format_rows``) writes for the first rows, and the whole CSV reads back to the Parquet table
bit for bit.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import signal
import statistics
import sys
import tempfile
from pathlib import Path

from timed_process import run_timed  # bench/ is the script's folder, first on sys.path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))

#: workload: (its FMU's instance name, the one variable recorded alone)
WORKLOADS = {"harsh": ("ControlledTemperature", "sensor.T"), "20sim": ("ControlledTemperature20sim", "T_room")}


def configs_of(workload: str) -> dict:
    name, one = WORKLOADS[workload]
    return {"one variable": (["--record", f"{name}.{one}"], {}),
            "all, no CSV": (["--record", f"{name}.*", "--no-csv"], {}),
            "all, CSV": (["--record", f"{name}.*"], {})}


def pure_of(workload: str) -> dict:
    return {"all, CSV, pure Python": (["--record", f"{WORKLOADS[workload][0]}.*"], {"COSIM_MASTER_PURE_PYTHON": "1"})}


def _cli() -> list[str]:
    exe = Path(sys.executable).with_name("cosim-master")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "master.cli"]


def run_once(fmu: Path, out: Path, args: list[str], env: dict, steps: int, supervise: bool,
             cli: list[str] | None = None) -> tuple[float, float]:
    """(wall s, CPU s) of one ``cosim-master run``."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = (cli or _cli()) + ["run", str(fmu), "--stop-time", repr(steps * 1e-4), "--step", "1e-4", "-o", str(out),
                    "--no-progress"] + args + ([] if supervise else ["--no-supervise"])
    proc, wall, cpu = run_timed(cmd, env={**os.environ, **env})
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr}")
    return wall, cpu


def check_csv(out: Path) -> list[str]:
    """The CSV against the reference writer (first rows, bytes) and against the Parquet table (every value)."""
    import pyarrow.csv as pc
    import pyarrow.parquet as pq

    from master.sinks.csv_text import format_rows
    table = pq.read_table(out / "results.parquet")
    lines = []
    head = table.slice(0, 5000)
    with open(out / "results.csv", "rb") as fh:
        fh.readline()
        got = b"".join(fh.readline() for _ in range(head.num_rows))
    lines.append(f"first {head.num_rows} rows as the Python reference writes them: "
                 f"{'yes' if got == format_rows(head).encode() else 'NO'}")
    back = pc.read_csv(out / "results.csv", convert_options=pc.ConvertOptions(
        column_types={f.name: f.type for f in table.schema}))
    same = back.num_rows == table.num_rows and all(
        x.dtype == y.dtype and x.tobytes() == y.tobytes()
        for x, y in ((a.to_numpy(), b.to_numpy()) for a, b in zip(back.combine_chunks().columns,
                                                                  table.combine_chunks().columns)))
    sizes = {name: os.path.getsize(out / name) / 1e6 for name in ("results.csv", "results.parquet")}
    lines.append(f"all {table.num_rows} rows x {table.num_columns} columns of results.csv read back to the Parquet "
                 f"table bit for bit: {'yes' if same else 'NO'}; "
                 + ", ".join(f"{name} {mb:.0f} MB" for name, mb in sizes.items()))
    return lines


def parts(out: Path) -> list[str]:
    """What the all-variables run spends on each part of the recording, measured here in one process on the run's
    own table, a block (4096 rows) at a time as the supervisor gets them: CPU seconds (user + system) each."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    from master.observers.recording import block_rows_for, block_table
    from master.sinks.csv import CsvSink
    from master.sinks.csv_native import Scratch, formatter, native_chunks
    from master.sinks.parquet import ParquetSink
    table = pq.read_table(out / "results.parquet").combine_chunks()
    step = block_rows_for(table.num_columns)
    spans = [(a, min(a + step, table.num_rows)) for a in range(0, table.num_rows, step)]

    def cpu():
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    def timed(fn):
        c0 = cpu()
        fn()
        return cpu() - c0
    took = {}
    if all(pa.types.is_float64(f.type) for f in table.schema):
        rows = np.stack([c.to_numpy() for c in table.columns], axis=1)     # the shared block's layout: row-major

        def each_block_once():          # as the supervisor does: a block's table lives until the next one comes
            for a, b in spans:
                block_table(table.schema, rows[a:b], [])
        took["block tables (the supervisor's copy out of the shared block)"] = timed(each_block_once)
        blocks = [block_table(table.schema, rows[a:b], []) for a, b in spans]
    else:       # Booleans too: each block's columns copied alone (the block tables' cost is the harsh table's)
        blocks = [pa.table([pa.array(c.to_numpy()) for c in table.slice(a, b - a).columns], schema=table.schema)
                  for a, b in spans]
    if formatter() is not None:
        scratch = Scratch()
        took["CSV text (C formatter)"] = timed(lambda: [len(c) for blk in blocks for c in native_chunks(blk, scratch)])
    with tempfile.TemporaryDirectory(prefix="bench_recording_parts_") as tmp:
        for name, sink in (("CSV text and its write (the CSV sink)", CsvSink()), ("Parquet sink", ParquetSink())):
            def write(sink=sink):
                sink.open(Path(tmp), table.schema)
                for blk in blocks:
                    sink.write(blk)
                sink.close()
            took[name] = timed(write)
    cells = table.num_rows * table.num_columns
    return [f"{name}: {s:.2f} s CPU" + (f" ({s / cells * 1e9:.0f} ns a value)" if "C formatter" in name else "")
            for name, s in took.items()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--no-supervise", action="store_true")
    ap.add_argument("--pure", action="store_true", help="also run the pure-Python CSV writer (once a round)")
    ap.add_argument("--before", metavar="CLI", help="another checkout's cosim-master, run in the same rounds")
    ap.add_argument("--parts", action="store_true", help="also measure each part of the recording in this process")
    ap.add_argument("--environment-bytecode", action="store_true",
                    help="keep the environment's bytecode setting (default: every checkout runs from compiled "
                         "bytecode kept in the bench's folder, as an installed package does)")
    ap.add_argument("--workload", choices=["harsh", "20sim", "both"], default="both")
    a = ap.parse_args(argv)
    from bench.recording.build import build_fmu
    workloads = ["harsh", "20sim"] if a.workload == "both" else [a.workload]
    # name -> (workload, args, env, cli); "<workload>: [before: ]<configuration>"
    configs = {}
    for w in workloads:
        own = {**configs_of(w), **(pure_of(w) if a.pure else {})}
        configs.update({f"{w}: {name}": (w, args, env, None) for name, (args, env) in own.items()})
        if a.before:
            configs.update({f"{w}: before: {name}": (w, args, env, [a.before])
                            for name, (args, env) in configs_of(w).items()})
    checks = []
    # a run's folder holds ~0.7 GB of results: a SIGTERM (a job's timeout, kill) unwinds like Ctrl-C, so the
    # temporary folder below is removed rather than left in /tmp
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    with tempfile.TemporaryDirectory(prefix="bench_recording_") as tmp:
        tmp = Path(tmp)
        if not a.environment_bytecode:
            # a checkout with __pycache__ folders and one without (PYTHONDONTWRITEBYTECODE=1 on this machine) start
            # ~0.1 s apart: every command gets its bytecode compiled once into one place and read from there
            os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
            os.environ["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
        fmus = {w: build_fmu(tmp, w) for w in workloads}
        for w, _, _, cli in configs.values():      # builds and caches (native loop, formatter, FMU unpacked)
            run_once(fmus[w], tmp / "warm", configs_of(w)["one variable"][0], {}, 1000, not a.no_supervise, cli)
        load0 = os.getloadavg()
        times: dict[str, list[tuple[float, float]]] = {k: [] for k in configs}
        for r in range(a.rounds):
            order = list(configs) if r % 2 == 0 else list(reversed(configs))
            for name in order:
                w, args, env, cli = configs[name]
                times[name].append(run_once(fmus[w], tmp / "out", args, env, a.steps, not a.no_supervise, cli))
        load1 = os.getloadavg()
        for w in workloads:
            run_once(fmus[w], tmp / "out", configs_of(w)["all, CSV"][0], {}, a.steps, not a.no_supervise)
            checks += [f"{w}: {line}" for line in check_csv(tmp / "out")]
            if a.parts:
                checks += [f"{w}: {line}" for line in parts(tmp / "out")]
    mode = "--no-supervise" if a.no_supervise else "supervised (the default)"
    print(f"ControlledTemperature stand-ins ({', '.join(workloads)}), {a.steps} steps of 1e-4 s, `cosim-master run`, "
          f"{mode}; {a.rounds} rounds alternating, medians")
    print("harsh: 120 Reals of their own, 110 changing in every step at full precision; 20sim: the 20-sim FMU's "
          "make-up (118 Reals over 50 value references, 19 parameters, 2 Booleans)")
    print("bytecode: " + ("the environment's" if a.environment_bytecode else "compiled once per checkout into the "
                                                                            "bench's folder (PYTHONPYCACHEPREFIX)"))
    print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, after {load1[0]:.2f} {load1[1]:.2f} "
          f"{load1[2]:.2f} (2 cores)\n")
    print("| recording | wall s | x one variable | CPU s | x one variable | walls |")
    print("|---|---:|---:|---:|---:|---|")
    for name, ts in times.items():
        w = configs[name][0]
        one = times[f"{w}: before: one variable" if ": before: " in name else f"{w}: one variable"]
        base_wall, base_cpu = statistics.median(w for w, _ in one), statistics.median(c for _, c in one)
        wall = statistics.median(w for w, _ in ts)
        cpu = statistics.median(c for _, c in ts)
        print(f"| {name} | {wall:.2f} | {wall / base_wall:.2f} | {cpu:.2f} | {cpu / base_cpu:.2f} | "
              f"{' '.join(f'{w:.2f}' for w, _ in ts)} |")
    print()
    for line in checks:
        print(f"- {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
