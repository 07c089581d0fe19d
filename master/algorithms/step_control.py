"""Step-size control shared by the variable-step algorithms (adaptive.py, ecco.py).

The law is the PI controller of Gustafsson, Lundh and Soederlind (1988), in the form both algorithms use:

    h_next = h * clamp(safety * r^-(k_I + k_P) * r_prev^k_P, min_rate, max_rate),  then clamped to [h_min, h_max]

with r the error estimate of the step just taken, normalised so that r <= 1 meets the tolerance, and r_prev
that of the step before. With k_I = 0.3/q, k_P = 0.4/q (q: the power of h in r) this is Gustafsson's PI.3.4
(Soederlind 2002, "Automatic control and adaptive time-stepping": beta_1 = 0.7, beta_2 = -0.4 in units of
1/q; Hairer, Noersett and Wanner, Solving ODEs I, sec. II.4, "stabilized step size control"). libcosim's ECCO
uses the same form with fixed gains (k_P = 0.2, k_I = 0.15) and keeps the step when r or r_prev is zero.
After a rejected step the elementary controller h * max(min_rate, safety * r^(-1/q)) gives the retry, and
the step after a rejection may not grow (Hairer et al., II.4).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..errors import CosimError

TINY = 1e-10        # an error estimate of zero counts as this (adaptive): the step grows at the maximum rate


@dataclass
class PIController:
    k_i: float
    k_p: float
    safety: float = 0.9
    min_rate: float = 0.2
    max_rate: float = 5.0
    h_min: float = 0.0
    h_max: float = math.inf
    keep_on_zero: bool = False      # libcosim's rule: r == 0 or r_prev == 0 keeps the step as it is
    r_prev: float = 1.0

    def accepted(self, h: float, r: float, after_rejection: bool = False) -> float:
        """The next step after an accepted step h with error estimate r."""
        if not math.isfinite(r):        # a NaN or infinite value (reported by the run's finiteness check)
            return self._clamp(h * self.min_rate)
        if self.keep_on_zero and (r == 0.0 or self.r_prev == 0.0):
            self.r_prev = r
            return self._clamp(h)
        r = max(r, TINY)
        rate = self.safety * r ** -(self.k_i + self.k_p) * self.r_prev ** self.k_p
        rate = min(max(rate, self.min_rate), 1.0 if after_rejection else self.max_rate)
        self.r_prev = r
        return self._clamp(h * rate)

    def rejected(self, h: float, r: float, q: float) -> float:
        """The retry after step h was rejected with error estimate r > 1 (r ~ h^q)."""
        return self._clamp(h * max(self.min_rate, min(1.0, self.safety * r ** (-1.0 / q))))

    def _clamp(self, h: float) -> float:
        return min(max(h, self.h_min), self.h_max)


def gustafsson(q: float, **limits) -> PIController:
    """PI.3.4 for an error estimate proportional to h^q."""
    return PIController(k_i=0.3 / q, k_p=0.4 / q, **limits)


def fit_to_grid(remaining: float, wanted: float) -> float:
    """The step that reaches the next grid point in equal steps of at most ``wanted``: no sliver of a step
    is left before the grid point (a step is only ever shortened)."""
    if wanted >= remaining:
        return remaining
    return remaining / math.ceil(remaining / wanted - 1e-9)


@dataclass
class StepLimits:
    """Tolerances and step bounds of a variable-step run (``--step-rtol``, ``--step-atol``, ``--min-step``,
    ``--max-step``, ``--initial-step``), checked once."""
    rtol: float
    atol: float
    h_min: float
    h_max: float
    h_initial: float

    @classmethod
    def from_options(cls, options, h: float, defaults: dict) -> "StepLimits":
        """``h``: the master step, which bounds every step (steps end on each master step); ``defaults``:
        step_rtol, min_step_ratio (of the maximum step), initial_ratio (of the maximum step)."""
        def given(name):
            value = getattr(options, name, None)
            return None if value is None else float(value)
        rtol = given("step_rtol") if given("step_rtol") is not None else defaults["step_rtol"]
        atol = given("step_atol") if given("step_atol") is not None else rtol
        for name, value in (("--step-rtol", rtol), ("--step-atol", atol)):
            if not (value >= 0 and math.isfinite(value)):
                raise CosimError(f"the tolerance must be a finite number >= 0, got {value:g}", element=name)
        if rtol == 0 and atol == 0:
            raise CosimError("--step-rtol and --step-atol are both 0: no step could meet that",
                             element="--step-rtol")
        h_max = given("max_step") if given("max_step") is not None else h
        h_min = given("min_step") if given("min_step") is not None else min(h_max, h) * defaults["min_step_ratio"]
        for name, value in (("--min-step", h_min), ("--max-step", h_max)):
            if not (value > 0 and math.isfinite(value)):
                raise CosimError(f"must be a positive time in seconds, got {value:g}", element=name)
        if h_min > h_max:
            raise CosimError(f"the minimum step {h_min:g} s is larger than the maximum step {h_max:g} s",
                             element="--min-step")
        if h_min > h:
            raise CosimError(f"the minimum step {h_min:g} s is larger than the master step {h:g} s (steps end on "
                             "every master step)", element="--min-step")
        h_max = min(h_max, h)
        h0 = given("initial_step") if given("initial_step") is not None else h_max * defaults["initial_ratio"]
        if not (h0 > 0 and math.isfinite(h0)):
            raise CosimError(f"must be a positive time in seconds, got {h0:g}", element="--initial-step")
        return cls(rtol, atol, h_min, h_max, min(max(h0, h_min), h_max))

    def describe(self) -> dict:
        return {"rtol": self.rtol, "atol": self.atol, "min_step": self.h_min, "max_step": self.h_max,
                "initial_step": self.h_initial}


@dataclass
class StepStats:
    """What run.json's ``algorithm_info`` reports about the steps of a variable-step run."""
    steps: int = 0
    rejected: int = 0
    rollbacks: int = 0
    fmu_calls: int = 0               # doStep calls
    above_tolerance: int = 0         # accepted at the minimum step with the estimate above the tolerance
    h_min: float = math.inf
    h_max: float = 0.0
    h_sum: float = 0.0
    rows: list = field(default_factory=list)     # per accepted step: (t_end, h, r, *extra) for steps.csv

    def accept(self, t_end: float, h: float, r: float, extra: tuple = ()) -> None:
        self.steps += 1
        self.h_min = min(self.h_min, h)
        self.h_max = max(self.h_max, h)
        self.h_sum += h
        self.rows.append((t_end, h, r, *extra))

    def describe(self) -> dict:
        return {"steps": self.steps, "rejected": self.rejected, "rollbacks": self.rollbacks,
                "fmu_calls": self.fmu_calls, "accepted_above_tolerance": self.above_tolerance,
                "step_min": self.h_min if self.steps else None, "step_max": self.h_max if self.steps else None,
                "step_mean": self.h_sum / self.steps if self.steps else None}
