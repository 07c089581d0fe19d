"""CPU time of one FMU step of UavWind: the step extension (uavsim/_wind_ext.c) against the Python step of the
same shell.

    python bench/bench_wind_step.py [--rounds 5] [--time 1500] [--src OTHER/fmu_sources]

For each wind probability of the paper campaign (ssp/campaigns/paper.yaml: 10 s episodes with 1 s ramps, 0.25 s
steps, one wind per UAV) it steps a fresh shell through --time simulated seconds, as a campaign run's wind FMU
does, timed with time.process_time; the variants alternate for --rounds rounds on several seeds (the machine is
shared: compare the best and the median, never one wall time).  Prints microseconds per call and the share of
the steps the extension left to Python (random draws).  --src loads the shell and its uavsim from another
checkout's fmu_sources (e.g. the commit before the extension: then the Python column alone).
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "fmu_sources"
PROBABILITIES = (0.0, 0.025, 0.05, 0.075, 0.1, 0.125, 0.15)


def shell_class(pure: bool, src: Path = SRC):
    """A factory of UavWind shells of ``src``, with their extension (pure: without, the Python step)."""
    spec = importlib.util.spec_from_file_location(f"bench_wind_{pure}", src / "UavWind.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)

    def make():
        shell = mod.UavWind(instance_name="bench", resources=str(src), visible=False)
        if pure or not hasattr(shell, "_ext"):
            shell._ext = None        # what COSIM_MASTER_PURE_PYTHON=1 gives
        return shell
    return make


def campaign_wind(make, probability: float, seed: int):
    s = make()
    s.probability, s.seed, s.stream = probability, seed, seed % 4
    s.decision_interval = s.duration = 10.0
    s.ramp = 1.0
    s.setup_experiment(0.0, None, None)
    s.exit_initialization_mode()
    return s


def run(make, probability: float, seed: int, stop: float, step: float = 0.25):
    """(CPU seconds, steps, steps declined by the extension) of one wind through [0, stop]."""
    s = campaign_wind(make, probability, seed)
    n = int(round(stop / step))
    declined = 0
    if getattr(s, "_ext", None) is not None:       # counted in a pass of its own, not the timed one
        c = campaign_wind(make, probability, seed)
        # the extension's own call: step(model, variables, t, h); before the model was passed, step(variables, t, h)
        args = (c.model, c.__dict__) if hasattr(type(c), "model") else (c.__dict__,)
        declined = sum(not c._ext(*args, i * step, step) and c.do_step(i * step, step) for i in range(n))
    do_step = s.do_step
    t0 = time.process_time()
    for i in range(n):
        do_step(i * step, step)
    return time.process_time() - t0, n, declined


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--time", type=float, default=1500.0, help="simulated seconds per run (the campaign's stop time)")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--src", type=Path, default=SRC, help="the fmu_sources folder to load (default: this checkout's)")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(a.src))          # its uavsim, not the installed one
    variants = {"python": shell_class(True, a.src), "C": shell_class(False, a.src)}
    if getattr(variants["C"](), "_ext", None) is None:
        print("no extension (not built, or not in --src): the Python step alone; to build it here: "
              "python -c 'import build_fmus; build_fmus.compile_extensions(\"uavsim\")' in fmu_sources/")
        del variants["C"]
    per_call = {(v, p): [] for v in variants for p in PROBABILITIES}
    declined = {}
    for _ in range(a.rounds):
        for p in PROBABILITIES:
            for v, make in variants.items():
                cpu = steps = dec = 0
                for seed in range(a.seeds):
                    c, n, d = run(make, p, 2021 + seed, a.time)
                    cpu, steps, dec = cpu + c, steps + n, dec + d
                per_call[v, p].append(cpu / steps * 1e6)
                if v == "C":
                    declined[p] = dec / steps
    print(f"UavWind.do_step, us CPU per call ({a.rounds} rounds x {a.seeds} winds x {a.time:g} s of 0.25 s steps; "
          f"load average {os.getloadavg()[0]:.2f})")
    print(f"{'probability':>11} {'python best':>11} {'median':>7} {'C best':>7} {'median':>7} {'ratio':>6} "
          f"{'declined':>8}")
    for p in PROBABILITIES:
        py, c = per_call["python", p], per_call.get(("C", p)) or [math.nan]
        print(f"{p:11.3f} {min(py):11.2f} {statistics.median(py):7.2f} {min(c):7.2f} {statistics.median(c):7.2f} "
              f"{statistics.median(py) / statistics.median(c):6.1f} {100 * declined.get(p, math.nan):7.2f}%")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
