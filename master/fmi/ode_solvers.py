"""The integrators a model-exchange component can run on: CVode (BDF or Adams, variable step, through fmpy) and
an explicit fixed-step forward Euler for cheap models. All offer what the model-exchange slave needs:
``step(t, t_next) -> (state event, roots, time reached)``, ``reset(t)`` after a discontinuity, ``stats()``.

Each solver reaches the model through ``calls`` (fmpy's calling convention: a ctypes double pointer and a
count): ``get_x``, ``set_x``, ``get_dx``, ``get_z``, ``get_nominals``, ``set_time``.
"""
from __future__ import annotations

import math
from ctypes import POINTER, c_double
from typing import NamedTuple

import numpy as np

from ..errors import CosimError
from .fmpy_adapter import CVode

SOLVERS = ("cvode-bdf", "cvode-adams", "euler")
DEFAULT_RTOL = 1e-10       # when neither the command line nor the FMU's DefaultExperiment gives a tolerance


class SolverChoice(NamedTuple):
    """What the run asks of every model-exchange component's integrator (``Options.solver``, ``solver_step``).
    ``step``: Euler's largest internal step; None takes each communication step whole. A named tuple, immutable
    as the frozen dataclass it was, not a dataclass (``master.records`` says why)."""
    name: str = "cvode-bdf"
    step: float | None = None

    def check(self) -> None:
        if self.name not in SOLVERS:
            raise CosimError(f"unknown solver {self.name!r}; one of {', '.join(SOLVERS)}", element="--solver")
        if self.step is not None and not (math.isfinite(self.step) and self.step > 0):
            raise CosimError(f"must be positive, got {self.step}", element="--solver-step")
        if self.step is not None and self.name != "euler":
            raise CosimError(f"an internal step is for the fixed-step solver (euler), not {self.name}",
                             element="--solver-step")


def make_solver(choice: SolverChoice, calls, nx: int, nz: int, start: float, rtol: float):
    if choice.name == "euler":
        return ForwardEuler(calls, nx, nz, choice.step)
    return CVode(calls, nx, nz, start, rtol, method=choice.name.removeprefix("cvode-"))


class ForwardEuler:
    """x(t+h) = x(t) + h * dx/dt(t), in equal internal steps of at most ``max_step`` between the times the caller
    asks for (communication points and time events). A state event is found when an event indicator changes
    domain (z > 0 or z <= 0) over an internal step; it is not located inside the step but handled at its end
    (the price of a cheap fixed-step method: the internal step bounds the timing error)."""

    def __init__(self, calls, nx: int, nz: int, max_step: float | None):
        self.calls = calls
        self.max_step = max_step
        self.x, self.dx = np.zeros(nx), np.zeros(nx)
        self.z, self.z_before = np.zeros(nz), np.zeros(nz)
        self._px, self._pdx = _pointer(self.x), _pointer(self.dx)
        self._pz = _pointer(self.z)
        self.steps = 0

    def reset(self, t: float) -> None:
        """After an event the indicators start from new values: sign changes count from here."""
        self._read_indicators()

    def _read_indicators(self) -> None:
        if self.z.size:
            self.calls.get_z(self._pz, self.z.size)

    def _next_time(self, t: float, t_next: float) -> float:
        if self.max_step is None:
            return t_next
        n = max(1, math.ceil((t_next - t) / self.max_step - 1e-9))   # 1e-9: a step that divides evenly
        return t_next if n == 1 else t + (t_next - t) / n

    def step(self, t: float, t_next: float):
        t_new = self._next_time(t, t_next)
        c = self.calls
        if self.x.size:
            c.set_time(t)
            c.get_x(self._px, self.x.size)
            c.get_dx(self._pdx, self.x.size)
            self.x += (t_new - t) * self.dx
            c.set_time(t_new)
            c.set_x(self._px, self.x.size)
        else:
            c.set_time(t_new)
        self.steps += 1
        self.z_before[:] = self.z
        self._read_indicators()
        crossed = (self.z > 0) != (self.z_before > 0)     # FMI: an event where z > 0 turns z <= 0, or back
        roots = np.where(crossed, np.where(self.z > self.z_before, 1, -1), 0).astype(np.int32)
        return bool(crossed.any()), roots, t_new

    def stats(self) -> dict:
        return {"steps": self.steps, "rhs_evaluations": self.steps if self.x.size else 0}


def _pointer(arr: np.ndarray):
    return arr.ctypes.data_as(POINTER(c_double))
