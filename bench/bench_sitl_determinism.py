"""How often do two lock-step SITL runs of the same scenario differ?  N pairs, each compared column by column.

Usage::

    ARDUPILOT_SITL=../shared/sitl/arducopter python bench/bench_sitl_determinism.py --pairs 20
    python bench/bench_sitl_determinism.py --pairs 10 --stall            # the second run of each pair stalled
    python bench/bench_sitl_determinism.py --pairs 5 --stall --fmu OLD/fmus/UavSitl.fmu   # another build
    python bench/bench_sitl_determinism.py --pairs 20 --jobs 3           # three pairs at a time (more load)
    python bench/bench_sitl_determinism.py --pairs 4 --random-stalls 12  # 12 stalls of random length each

The scenario is the determinism test's (tests/fmu_sources/sitlsim/test_sitl_vehicle.py: one UAV, one target 36 m out, 5 m
takeoff, seed 3).  A pair is two ``master.run`` calls of one SSP in one process; ``--stall`` adds the test's
``StallAfterSteps`` observer to the second run (a 1.5 s pause of the master after steps 15 and 120, so that
SITL re-sends its servo frame, then SITL frozen for 0.6 s: the wall-clock accidents of a loaded machine, made
certain); ``--random-stalls K`` stalls it instead after K random steps, each with a pause of 0.1-1.6 s and
SITL frozen for 0-0.8 s (drawn from the pair number, so every pair stalls differently).  ``--fmu`` puts
another UavSitl.fmu into the SSP (e.g. main's, for a before/after).  Per pair: the recorded columns that
differ (all but ``sitl_instance``, which says where the vehicle ran), the first mission time at which they do,
and how often SITL re-sent a frame in the second run ("resending servos" in its sitl.log: it waited > 1 s for
our answer; the wait after the last step counts too).  One table is printed.
"""
from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
import zipfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
STALL_STEPS = (15, 120)


def _tests():
    sys.path.insert(0, str(REPO / "tests" / "sitl"))
    import test_sitl_vehicle as tv
    return tv


def with_fmu(ssp: Path, fmu: Path) -> Path:
    """A copy of ``ssp`` whose resources/UavSitl.fmu is ``fmu``."""
    out = ssp.with_name(ssp.stem + "_fmu.ssp")
    with zipfile.ZipFile(ssp) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = fmu.read_bytes() if item.filename == "resources/UavSitl.fmu" else src.read(item)
            dst.writestr(item, data)
    return out


def stalls(k: int, fixed: bool, random_stalls: int):
    """The stall plan of pair k's second run: {step: (pause s, hold s)}, or None."""
    if random_stalls:
        import random
        rng = random.Random(k)
        return {rng.randrange(1, 380): (rng.uniform(0.1, 1.6), rng.uniform(0.0, 0.8)) for _ in range(random_stalls)}
    return {n: (1.5, 0.6) for n in STALL_STEPS} if fixed else None


def one_pair(k: int, root: str, stall: bool, fmu: str | None, random_stalls: int = 0) -> dict:
    import master
    tv = _tests()
    folder = Path(root) / f"pair{k}"
    folder.mkdir(parents=True)
    ssp = tv.scenario(folder)
    if fmu:
        ssp = with_fmu(ssp, Path(fmu))
    walls, frames = [], []
    plan = stalls(k, stall, random_stalls)
    for name in ("a", "b"):
        observers = [tv.StallAfterSteps(folder / name, plan)] if plan and name == "b" else []
        t0 = time.perf_counter()
        res = master.run(ssp, output=folder / name, raise_on_error=False, write_csv=False, observers=observers)
        for ob in observers:
            for timer in ob.timers:
                timer.join()
        walls.append(time.perf_counter() - t0)
        if res.metadata["outcome"] != "completed":
            return {"pair": k, "error": f"run {name}: {res.metadata.get('error')}", "wall": walls}
        frames.append(res.frame)
    fa, fb = frames
    cols = [c for c in fa.columns if not c.endswith(".sitl_instance")]
    diff = [c for c in cols if c not in fb.columns or not fa[c].equals(fb[c])] if len(fa) == len(fb) else cols
    first = None
    if diff:
        n = min(len(fa), len(fb))
        for i in range(n):
            if any(c in fb.columns and not (fa[c].iloc[i] == fb[c].iloc[i]) for c in diff):
                first = float(fa["time"].iloc[i])
                break
    log = folder / "b" / "sitl" / "uav1_dyn" / "sitl.log"
    resent = log.read_text(errors="replace").count("resending servos") if log.is_file() else -1
    return {"pair": k, "diff": diff, "first": first, "resent": resent, "wall": walls, "rows": len(fa)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=1, help="pairs run at the same time (processes)")
    ap.add_argument("--stall", action="store_true", help="stall the second run of each pair (see above)")
    ap.add_argument("--random-stalls", type=int, default=0, metavar="K",
                    help="stall the second run after K random steps, each differently (see above)")
    ap.add_argument("--fmu", help="use this UavSitl.fmu instead of fmus/UavSitl.fmu")
    ap.add_argument("--keep", help="keep the run folders here (default: a temporary folder, removed)")
    a = ap.parse_args(argv)
    if not os.environ.get("ARDUPILOT_SITL"):
        print("set ARDUPILOT_SITL to an arducopter SITL build", file=sys.stderr)
        return 2
    root = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="sitldet_"))
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    try:
        with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as pool:
            results = list(pool.map(one_pair, range(a.pairs), [str(root)] * a.pairs, [a.stall] * a.pairs,
                                    [a.fmu] * a.pairs, [a.random_stalls] * a.pairs))
    finally:
        if not a.keep:
            shutil.rmtree(root, ignore_errors=True)
    total = time.perf_counter() - t0
    how = f"{a.random_stalls} random" if a.random_stalls else "steps " + ",".join(map(str, STALL_STEPS)) \
        if a.stall else "no"
    print(f"# SITL lock-step determinism: {a.pairs} pairs, stalls in run b: {how}, "
          f"fmu={a.fmu or 'fmus/UavSitl.fmu'}, jobs={a.jobs}, {platform.node()}, load "
          f"{os.getloadavg()[0]:.1f}, {total:.0f} s")
    print("| pair | rows | differing columns | first differing t (s) | SITL re-sent frames (run b) | wall a / b (s) |")
    print("|---:|---:|---:|---:|---:|---|")
    differ = failed = 0
    for r in results:
        walls = " / ".join(f"{w:.1f}" for w in r["wall"])
        if "error" in r:
            failed += 1
            print(f"| {r['pair']} | - | error: {r['error']} | - | - | {walls} |")
            continue
        differ += bool(r["diff"])
        first = "-" if r["first"] is None else f"{r['first']:g}"
        print(f"| {r['pair']} | {r['rows']} | {len(r['diff'])} | {first} | {r['resent']} | {walls} |")
    print(f"\n{differ} of {a.pairs - failed} pairs differ" + (f" ({failed} failed to run)" if failed else ""))
    return 1 if differ or failed else 0


if __name__ == "__main__":
    sys.exit(main())
