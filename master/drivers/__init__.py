"""Step drivers: accelerators of the step loop (``Execution._steps``, the reference) behind one interface
(``base.StepDriver``), asked in one place, :func:`driver_for`.

- ``native.py`` + ``native_loop.c``: the steps of a system of native FMI 2.0/3.0 co-simulation FMUs in C.
"""
from __future__ import annotations

from .. import accel
from .base import DriverRun, StepDriver
from .native import NATIVE

#: every step driver, in the order they are asked; the first that can run an execution's steps runs them
DRIVERS: tuple[StepDriver, ...] = (NATIVE,)


def driver_for(ex) -> DriverRun | None:
    """The driver that runs the steps of the initialized execution ``ex``, or None (the reference loop runs
    them); each driver's answer goes into run.json under its name. Called once per execution."""
    off = ("switched off" if not ex.options.native_loop
           else f"{accel.ENV} is set" if not accel.enabled() else None)
    chosen = None
    for driver in DRIVERS:
        reason = off or ("another driver runs the steps" if chosen is not None else driver.why_not(ex))
        ex.metadata[driver.name] = {"used": reason is None, **({"reason": reason} if reason else {})}
        if reason is None:
            chosen = driver.bind(ex)
    return chosen


__all__ = ["DRIVERS", "DriverRun", "StepDriver", "driver_for"]
