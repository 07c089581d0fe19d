"""The declarations (master/accel.py) of the accelerators of the step loop and of the fixed-step algorithm step,
checked by ``tests/accelerators/`` against their references on whole runs:

- ``master.native-loop``: the native step driver (master/drivers/native.py) against the reference step loop
  ``Execution._steps`` (the same run with the drivers off, ``native_loop=False``);
- ``master.compiled-step``: the generated step (master/algorithms/compiled.py) against
  ``fixed_step.reference_step`` (the same run with ``COSIM_MASTER_PURE_PYTHON=1``; the drivers are off in both).

A case is one of the shipped coupling SSPs (``ssp/coupling/``: native C FMUs and pythonfmu ones, with a
feedthrough, an algebraic loop and a stiff coupling) with a generated algorithm, step (also one that leaves a
shorter final step), stop time, record interval and step multiple. The compiled step also runs, once per seed, a
short stretch of one of the other scenarios shipped in ``ssp/`` (in-process FMUs whose calls it writes into its
own code, monitors that take components out and end runs). Each run returns what it observes: the
recorded table, column by column, the events, and the run's facts (steps done, last time, early end, outcome,
error, doStep counts, rows). These declarations run whole executions, so they sit above ``runner`` (nothing of
the engine imports this module).
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from . import accel

SHIPPED = Path(__file__).resolve().parents[1] / "ssp"
COUPLING = SHIPPED / "coupling"
NATIVE_SSPS = ("oscillator_fd.ssp", "oscillator_dd.ssp", "oscillator_stiff.ssp", "algebraic_loop.ssp")
PYTHON_SSPS = ("oscillator_fd_py.ssp", "oscillator_dd_py.ssp", "algebraic_loop_py.ssp")
FACTS = ("outcome", "error", "failed_at", "last_time", "steps_done", "ended_early", "fmu_calls", "rows_recorded")


def _settings(rng, ssp: str) -> dict:
    """A run of ``ssp``: algorithm, step (sometimes one that does not divide the stop time), stop, record
    interval, and sometimes B on a step multiple."""
    h = rng.choice([0.01, 0.02, 0.05, 0.1] if "loop" in ssp else [0.005, 0.01, 0.02, 0.03])
    kw = {"algorithm": rng.choice(["jacobi", "gauss-seidel"]), "step": h,
          "record_interval": h * rng.choice([1, 1, 3, 7])}
    steps = rng.randrange(20, 150)
    if "oscillator" in ssp and rng.random() < 0.4:
        kw["step_multiples"] = {"B": rng.choice([2, 3])}
        kw["stop_time"] = steps * h                  # a step multiple needs a whole number of steps
    else:
        kw["stop_time"] = (steps + rng.choice([0, 0, 0.5])) * h      # 0.5: a shorter final step
    return kw


@contextmanager
def _pure_python(on: bool):
    old = os.environ.get(accel.ENV)
    if on:
        os.environ[accel.ENV] = "1"
    else:
        os.environ.pop(accel.ENV, None)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(accel.ENV, None)
        else:
            os.environ[accel.ENV] = old


def _scenarios() -> list[str]:
    """The shipped scenarios besides the coupling ones that run on their own (the sitl ones need a simulator
    installed beside them)."""
    return sorted(p.name for p in SHIPPED.glob("*.ssp") if not p.name.startswith("sitl"))


def _scenario_settings(rng) -> dict:
    h = rng.choice([0.1, 0.25, 0.5])
    return {"algorithm": rng.choice(["jacobi", "gauss-seidel"]), "step": h, "stop_time": rng.randrange(20, 160) * h,
            "record_interval": h * rng.choice([1, 2])}


def _observed(ssp: str, kw: dict, *, pure: bool, drivers: bool):
    """(what a run observes, its run.json facts)."""
    from .runner import run
    with _pure_python(pure):
        res = run((COUPLING if (COUPLING / ssp).is_file() else SHIPPED) / ssp, output=None, raise_on_error=False,
                  native_loop=drivers, record=["*"], **kw)
    frame = res.frame
    # a column of strings or bytes as a list of them (an object array's bytes would be its pointers)
    table = {} if frame is None else {c: (col.tolist() if col.dtype == object else col)
                                      for c, col in ((c, frame[c].to_numpy()) for c in frame.columns)}
    return {"table": table, "events": list(res.events), **{k: res.metadata.get(k) for k in FACTS}}, res.metadata


class _Runs:
    replaces = ""
    ssps: tuple = ()

    def load(self):
        if not accel.enabled():
            return None, f"{accel.ENV} is set"
        if not COUPLING.is_dir():
            return None, f"the coupling SSPs are not in {COUPLING} (a source checkout has them)"
        return self._load()

    def _load(self):
        return True, None

    def cases(self, rng):
        for _ in range(3):
            ssp = rng.choice(self.ssps)
            yield ssp, _settings(rng, ssp)


class NativeLoopDeclaration(_Runs):
    name = "master.native-loop"
    replaces = "master.execution:Execution._steps"
    ssps = NATIVE_SSPS

    def _load(self):
        from .drivers.native import library
        return library()

    def reference(self, case):
        return _observed(*case, pure=False, drivers=False)[0]

    def accelerated(self, impl, case):
        got, meta = _observed(*case, pure=False, drivers=True)
        if not meta.get("native_loop", {}).get("used"):
            raise AssertionError(f"the native loop did not run: {meta.get('native_loop')}")
        return got


class CompiledStepDeclaration(_Runs):
    name = "master.compiled-step"
    replaces = "master.algorithms.fixed_step:reference_step"
    ssps = NATIVE_SSPS + PYTHON_SSPS

    def cases(self, rng):
        yield from super().cases(rng)
        scenarios = _scenarios()
        if scenarios:
            yield rng.choice(scenarios), _scenario_settings(rng)

    def reference(self, case):
        return _observed(*case, pure=True, drivers=False)[0]

    def accelerated(self, impl, case):
        return _observed(*case, pure=False, drivers=False)[0]


NATIVE_LOOP = NativeLoopDeclaration()
COMPILED_STEP = CompiledStepDeclaration()
