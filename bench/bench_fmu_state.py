"""Cost of saving and restoring the UAV FMUs' state (uavsim.fmi.StateMixin), against copy.deepcopy.

    python bench/bench_fmu_state.py [--time 600] [--repeat 30]

Runs ssp/paper_free_1uav_A.ssp in process (wind on, 1 s steps) to --time seconds, then times, per FMU,
``_get_fmu_state`` and ``_set_fmu_state`` (what iterative coupling calls every step) and ``copy.deepcopy`` of
the same attributes with the loaded kernels shared (a ctypes library cannot be deep-copied; pythonfmu has no
full-state default to compare with: it saves the registered variables only). Prints one row per FMU (milliseconds per call, best of --repeat). The wind's state
grows with simulated time (it keeps every drawn interval), so --time matters.
"""
from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times) * 1e3


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=30)
    a = ap.parse_args(argv)
    from master.execution import Execution
    from uavsim import kernels
    from uavsim.fmi import _NOT_STATE
    ex = Execution(REPO / "ssp" / "paper_free_1uav_A.ssp", output=None, step=1.0,
                   params={"wind.probability": 0.5, "wind.turbulence": True})
    ex.initialize()
    ex.simulate_until(a.time)
    print(f"t = {ex.time:g} s, best of {a.repeat}, ms per call")
    print(f"{'FMU':12s} {'get':>8s} {'set':>8s} {'deepcopy':>9s}")
    for s in ex.rt.slaves:
        obj = s.obj
        token = obj._get_fmu_state()
        own = {k: v for k, v in obj.__dict__.items() if k not in _NOT_STATE}
        get = best(obj._get_fmu_state, a.repeat)
        put = best(lambda: obj._set_fmu_state(token), a.repeat)
        shared = {id(k): k for k in (*kernels._loaded.values(), *kernels._found.values())}
        deep = best(lambda: copy.deepcopy(own, dict(shared)), a.repeat)
        print(f"{s.name:12s} {get:8.2f} {put:8.2f} {deep:9.2f}")
    ex.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
