"""CPU time of one FMU step of UavDynamics and UavBattery: the step extensions (uavsim/_dynamics_ext.c,
_battery_ext.c) against the Python step of the same shells.

    python bench/bench_uav_step_ext.py [--src fmu_sources] [--calls 100000] [--rounds 5]

Loads the shells from --src (another checkout's fmu_sources, with its uavsim on PYTHONPATH, measures that
code: e.g. the commit before the extensions), brings each into a typical state (Dynamics: flying to a far
setpoint in wind, holding, landed; Battery: motors on) and times --calls do_step calls with time.process_time,
the variants alternating for --rounds rounds (the machine is shared: compare the best and the median, never one
wall time). Prints microseconds per call.
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def load_shell(src: Path, name: str, variant: str):
    spec = importlib.util.spec_from_file_location(f"bench_shell_{name}", src / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    shell = getattr(mod, name)(instance_name="bench", resources=str(src), visible=False)
    shell.exit_initialization_mode()
    if variant == "python":
        shell.__dict__["_ext"] = None
    return shell


def dynamics_in(state: str, shell):
    shell.do_step(0.0, 0.1)
    if state != "preflight":
        shell.cmd = 1
        for _ in range(300):
            shell.do_step(0.0, 0.1)
    if state == "goto":
        shell.cmd, shell.sp_x, shell.sp_y, shell.wind_x, shell.wind_y = 2, 1e6, 3e5, 3.0, -1.5
    elif state == "hold":
        shell.cmd, shell.wind_x = 0, 3.0
    elif state == "landed":
        shell.cmd = 3
        while shell.phase != 4:
            shell.do_step(0.0, 0.1)
    shell.do_step(0.0, 0.1)
    return shell


def battery_in(shell):
    shell.phase, shell.airspeed, shell.vz = 2, 8.0, 0.5
    shell.do_step(0.0, 0.1)
    return shell


def per_call(shell, calls: int) -> float:
    step = shell.do_step
    t = time.process_time()
    for _ in range(calls):
        step(0.0, 0.1)
    return (time.process_time() - t) / calls * 1e6


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=REPO / "fmu_sources")
    ap.add_argument("--calls", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    src = a.src.resolve()
    sys.path.insert(0, str(src))
    probe = load_shell(src, "UavDynamics", "ext")
    variants = ["ext", "python"] if getattr(probe, "_ext", None) is not None else ["python"]
    cases = []
    for variant in variants:
        for state in ("goto", "hold", "landed", "preflight"):
            cases.append((f"UavDynamics {state}", variant, dynamics_in(state, load_shell(src, "UavDynamics", variant))))
        cases.append(("UavBattery motors on", variant, battery_in(load_shell(src, "UavBattery", variant))))
    times: dict = {(c, v): [] for c, v, _ in cases}
    for _ in range(a.rounds):
        for case, variant, shell in cases:
            times[case, variant].append(per_call(shell, a.calls))
    print(f"{'case':24s} {'variant':8s} {'best us':>8s} {'median us':>10s}   ({src}, {a.rounds} rounds x {a.calls} calls)")
    for (case, variant), ts in sorted(times.items()):
        print(f"{case:24s} {variant:8s} {min(ts):8.2f} {statistics.median(ts):10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
