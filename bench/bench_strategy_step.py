"""CPU cost of one UavStrategy do_step, with and without its compiled step (uavsim/_strategy_ext.c, the accelerator
of Strategy.step declared in uavsim/strategy_accel.py).

    python bench/bench_strategy_step.py [--uavs 4] [--step 0.1] [--rounds 5] [--no-zones]

Runs the 4-UAV scaling mission once (bench_uav_scaling.make_scenario, in process), recording every strategy
FMU's inputs at each do_step and its state at the first one; then replays those steps on the same shells,
the fast path on and off alternately (the shell module's ``_FAST_STEP``), each round from the recorded state,
and prints the CPU time (time.process_time) per do_step call: the replay loop minus the same loop without the
do_step calls.  The replay also checks that both ways publish the same outputs (bit for bit), and the table
says how many steps the fast path did itself (the extension's counters).
"""
from __future__ import annotations

import argparse
import copy
import struct
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

INPUTS = ("x", "y", "z", "vx", "vy", "consumed", "phase", "command")
OUTPUTS = ("cmd", "sp_x", "sp_y", "sp_z", "mission_state", "targets_assigned", "targets_visited", "photo_count",
           "last_photo_target", "current_target", "avoiding", "avoid_count", "last_photo_time", "last_photo_x",
           "last_photo_y")


def record(n: int, step: float, zones: bool):
    """[(shell, state at its first do_step, [(t, h, inputs), ...])] of every strategy FMU of the mission."""
    import bench_uav_scaling as B
    from master import runner
    from master.fmi import inprocess
    from uavstudy.build import build_ssp

    tmp = Path(tempfile.mkdtemp())
    ssp = tmp / "s.ssp"
    build_ssp(B.make_scenario(n, step=step, zones=zones), ssp)
    runs: dict[int, tuple] = {}
    instantiate = inprocess.PythonFmuSlave.instantiate

    def hook(self):
        cls = self.cls
        if cls.__name__ == "UavStrategy" and not getattr(cls, "_bench_wrapped", False):
            cls._bench_wrapped = True
            plain = cls.do_step

            def do_step(shell, t, h):
                if id(shell) not in runs:
                    runs[id(shell)] = (shell, _snapshot(shell), [])
                d = shell.__dict__
                runs[id(shell)][2].append((t, h, tuple((k, d[k]) for k in INPUTS)))
                return plain(shell, t, h)
            cls.do_step = do_step
            cls._bench_plain = plain
        return instantiate(self)

    inprocess.PythonFmuSlave.instantiate = hook
    try:
        runner.run(ssp, output=tmp / "out", write_csv=False, raise_on_error=False)
    finally:
        inprocess.PythonFmuSlave.instantiate = instantiate
    return list(runs.values())


def _snapshot(shell) -> dict:
    """A copy of the shell's attributes sharing the zone geometry (which the step never changes; FMI get state
    cannot copy a strategy with zones: shapely's prepared geometries do not pickle)"""
    model = shell.__dict__.get("_model")
    memo = {} if model is None else {id(model.zones): model.zones}
    return {k: copy.deepcopy(v, memo) for k, v in shell.__dict__.items()}


def _restore(shell, state: dict) -> None:
    d = shell.__dict__
    d.clear()
    d.update(_snapshot_of(state))


def _snapshot_of(state: dict) -> dict:
    model = state.get("_model")
    memo = {} if model is None else {id(model.zones): model.zones}
    return {k: copy.deepcopy(v, memo) for k, v in state.items()}


def _bits(values):
    return tuple(struct.pack("<d", v) if isinstance(v, float) else (type(v), v) for v in values)


class _ShellModule:
    """The globals of a shell's module (its do_step reads _FAST_STEP there), also when the in-process loader
    imported the FMU in isolation (stale FMUs: not in sys.modules)."""

    def __init__(self, shell):
        object.__setattr__(self, "g", type(shell)._bench_plain.__globals__)

    def __getattr__(self, name):
        return self.g[name]

    def __setattr__(self, name, value):
        self.g[name] = value


def replay(runs, fast: bool):
    """(CPU s of the do_step calls, number of calls, the outputs after each call); the extension's counters
    count the last pass (the one giving the outputs)"""
    total, calls, outs = 0.0, 0, []
    passes = []
    for shell, state, steps in runs:
        module = _ShellModule(shell)
        saved = module._FAST_STEP
        module._FAST_STEP = saved if fast else None
        try:
            plain = type(shell)._bench_plain
            _restore(shell, state)
            upd, d = shell.__dict__.update, shell.__dict__
            c = time.process_time()
            for t, h, inputs in steps:
                upd(inputs)
                plain(shell, t, h)
            busy = time.process_time() - c
            c = time.process_time()
            for t, h, inputs in steps:
                upd(inputs)
            idle = time.process_time() - c
            total += busy - idle
            calls += len(steps)
            passes.append((shell, state, steps, module, fast))
        finally:
            module._FAST_STEP = saved
    ext = _ShellModule(runs[0][0])._EXT
    if ext is not None:
        ext.reset_stats()
    for shell, state, steps, module, fast in passes:
        saved = module._FAST_STEP
        module._FAST_STEP = saved if fast else None
        try:
            plain, d = type(shell)._bench_plain, shell.__dict__
            _restore(shell, state)
            for t, h, inputs in steps:
                d.update(inputs)
                plain(shell, t, h)
                outs.append(_bits([d[k] for k in OUTPUTS]))
        finally:
            module._FAST_STEP = saved
    return total, calls, outs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uavs", type=int, default=4)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--no-zones", action="store_true")
    args = ap.parse_args(argv)
    runs = record(args.uavs, args.step, not args.no_zones)
    ext = _ShellModule(runs[0][0])._EXT
    if ext is None:
        print("the compiled step is not available here (no compiled extension, or COSIM_MASTER_PURE_PYTHON set)")
    per = {True: [], False: []}
    same = True
    for _ in range(args.rounds):
        for fast in ((True, False) if ext is not None else (False,)):
            cpu, calls, outs = replay(runs, fast)
            per[fast].append(cpu / calls * 1e6)
            if fast:
                stats = ext.stats()
                fast_outs = outs
            elif ext is not None:
                same = same and outs == fast_outs
    print(f"UavStrategy do_step, {args.uavs}-UAV scaling mission, step {args.step} s, {calls} calls per replay, "
          f"{args.rounds} rounds (CPU us per call: min / median)")
    print(f"{'path':10s} {'min':>7s} {'median':>7s}")
    for fast in (False, True):
        v = sorted(per[fast])
        if v:
            print(f"{'fast' if fast else 'python':10s} {v[0]:7.2f} {v[len(v) // 2]:7.2f}")
    if ext is not None:
        handled, edges = stats.pop("handled"), stats.pop("edge_clears")
        print(f"fast path did {handled} of {calls} steps ({100.0 * handled / calls:.1f} %); declined: "
              + ", ".join(f"{k} {v}" for k, v in stats.items() if v)
              + f"; segments near a zone found clear by its edges: {edges}")
        print(f"outputs identical with and without it: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
