"""What loading in-process FMUs in isolation costs (master/fmi/inprocess.py).

    python bench/bench_inprocess_isolation.py [--time 1800] [--repeat 3]

1. The check every in-process FMU goes through once per process: which of the top-level names its resources
   provide are imported from other code (hashing the bundled and the imported .py files), for each shipped FMU
   in a process that imported the installed uavsim (as every UAV run does); first call and cached.
2. ssp/paper_free_1uav_A.ssp run in process to --time seconds, each run in a fresh process (best of --repeat),
   as shipped (imported as usual) and with every FMU's bundled uavsim/params.py changed by one comment line (so
   each FMU is loaded in isolation, with the same behaviour): wall time, and whether the results are identical.
"""
from __future__ import annotations

import argparse
import io
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SSP = REPO / "ssp" / "paper_free_1uav_A.ssp"

RUN = """
import sys, time
import master
t = time.perf_counter()
res = master.run(sys.argv[1], output=sys.argv[2], inprocess=True, stop_time=float(sys.argv[3]), record=["*"])
print(time.perf_counter() - t)
"""


def check_cost() -> list[tuple[str, float, float]]:
    import uavstudy.names  # noqa: F401  (imports the installed uavsim)
    from master.fmi import inprocess_import as inprocess
    from master.fmi.cache import load_fmu
    rows = []
    for fmu in sorted((REPO / "fmus").glob("*.fmu")):
        res = load_fmu(fmu).unzip_dir / "resources"
        inprocess._digest.cache_clear()
        t0 = time.perf_counter()
        clashes = inprocess._clashes(res, inprocess._provided(res))
        t1 = time.perf_counter()
        inprocess._clashes(res, inprocess._provided(res))
        t2 = time.perf_counter()
        assert not clashes, (fmu.name, clashes)
        rows.append((fmu.name, (t1 - t0) * 1e3, (t2 - t1) * 1e3))
    return rows


def with_changed_uavsim(src: Path, dst: Path) -> None:
    """The SSP with each FMU's bundled uavsim/params.py one comment line longer."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename.endswith(".fmu"):
                buf = io.BytesIO()
                with zipfile.ZipFile(io.BytesIO(data)) as fin, zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as fout:
                    for member in fin.infolist():
                        body = fin.read(member.filename)
                        if member.filename == "resources/uavsim/params.py":
                            body += b"# a changed copy: loaded in isolation\n"
                        fout.writestr(member, body)
                data = buf.getvalue()
            zout.writestr(item, data)


def timed_runs(ssp: Path, out: Path, stop: float, repeat: int) -> float:
    best = float("inf")
    for i in range(repeat):
        proc = subprocess.run([sys.executable, "-c", RUN, str(ssp), str(out / str(i)), str(stop)],
                              capture_output=True, text=True, check=True)
        best = min(best, float(proc.stdout.split()[-1]))
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time", type=float, default=1800.0)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    print("| shipped FMU | check, first call (ms) | check, cached (ms) |")
    print("|---|---:|---:|")
    for name, first, cached in check_cost():
        print(f"| {name} | {first:.2f} | {cached:.3f} |")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        changed = tmp / "changed.ssp"
        with_changed_uavsim(SSP, changed)
        shared = timed_runs(SSP, tmp / "shared", a.time, a.repeat)
        isolated = timed_runs(changed, tmp / "isolated", a.time, a.repeat)
        same = ((tmp / "shared" / "0" / "results.csv").read_bytes()
                == (tmp / "isolated" / "0" / "results.csv").read_bytes())
        isolated_log = "loaded in isolation" in (tmp / "isolated" / "0" / "fmu.log").read_text()
    print()
    print(f"| {SSP.name}, {a.time:g} s in process | wall time (s, best of {a.repeat}) | results |")
    print("|---|---:|---|")
    print(f"| shipped (imported as usual) | {shared:.2f} | |")
    print(f"| changed copies (isolated: {isolated_log}) | {isolated:.2f} | {'identical' if same else 'DIFFERENT'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
