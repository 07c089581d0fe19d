"""The algorithms' own settings in one table: name, type, default, and where each may be given.

Every setting here is accepted, under the same name, from the command line (``--extrapolation``,
``--coupling-tol``: dashes for underscores), the API (``master.run(extrapolation=1)``), a campaign's ``run:``
keys and grid axes, and the SSD settings annotation (``<cm:Settings extrapolation="1" couplingTol="1e-8">``:
the camelCase of the name). A new algorithm setting is one row in ``ALGORITHM_OPTIONS`` plus its field in
``execution.Options`` (here, not registered by the algorithm's module: the command line, the campaign format
and the SSD reader read the table before any algorithm is imported); run.json records each value and where it
came from (``settings_sources``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .errors import CosimError


class AlgorithmOption(NamedTuple):
    """One setting. A named tuple, immutable as the frozen dataclass it was, not a dataclass
    (``master.records`` says why)."""
    name: str                   # Options field, campaign key
    kind: str                   # "int", "float", "choice"
    default: object             # None: derived (see help)
    help: str
    choices: tuple = ()
    minimum: float | None = None        # inclusive
    positive: bool = False
    applies_to: tuple = ()              # the algorithms that read it (empty: every one); a study sweeps it for these

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    @property
    def ssd_attribute(self) -> str:
        head, *rest = self.name.split("_")
        return head + "".join(w.capitalize() for w in rest)

    def parse(self, raw, element: str):
        """The value of ``raw`` (text from a file or the command line, or a YAML/Python value), or a one-line
        CosimError naming ``element``."""
        if self.kind == "choice":
            value = str(raw).strip() if raw is not None else raw
            if value not in self.choices:
                raise CosimError(f"must be one of {', '.join(map(str, self.choices))}, got {raw!r}", element=element)
            return value
        if isinstance(raw, bool):
            raise CosimError(f"expected a number, got {raw!r}", element=element)
        try:
            value = int(str(raw).strip()) if self.kind == "int" else float(raw)
        except (TypeError, ValueError):
            what = "an integer" if self.kind == "int" else "a number"
            raise CosimError(f"expected {what}, got {raw!r}", element=element) from None
        if self.kind == "int" and isinstance(raw, float) and raw != value:
            raise CosimError(f"expected an integer, got {raw!r}", element=element)
        if not math.isfinite(value):
            raise CosimError(f"expected a finite number, got {raw!r}", element=element)
        if self.choices and value not in self.choices:
            raise CosimError(f"must be one of {', '.join(map(str, self.choices))}, got {raw!r}", element=element)
        if self.positive and not value > 0:
            raise CosimError(f"must be positive, got {raw!r}", element=element)
        if self.minimum is not None and value < self.minimum:
            raise CosimError(f"must be >= {self.minimum:g}, got {raw!r}", element=element)
        return value


ALGORITHM_OPTIONS: dict[str, AlgorithmOption] = {o.name: o for o in (
    AlgorithmOption("extrapolation", "int", 0, "jacobi, gauss-seidel: coupled inputs extrapolated from the last "
                    "K+1 output samples (0 held, 1 linear, 2 quadratic; docs/coupling.md)", choices=(0, 1, 2),
                    applies_to=('jacobi', 'gauss-seidel', 'adaptive')),
    AlgorithmOption("gs_interpolation", "int", 0, "gauss-seidel: inputs already computed in the step get the "
                    "mean over the step of the polynomial through the new value and M earlier samples (0 held as "
                    "computed, 1 linear, 2 quadratic; docs/coupling.md)", choices=(0, 1, 2),
                    applies_to=('gauss-seidel', 'iterative')),
    AlgorithmOption("input_derivatives", "int", 0, "jacobi: 1 gives FMUs that can interpolate inputs the "
                    "extrapolation polynomial itself (value and derivatives at the step's start, "
                    "fmi2SetRealInputDerivatives) instead of its mean: order K + 1 (needs K >= 1); 2 fits the "
                    "polynomial to the producers' output derivatives too (fmi2GetRealOutputDerivatives): order "
                    "K + 2 (docs/coupling.md)", choices=(0, 1, 2),
                    applies_to=('jacobi',)),
    AlgorithmOption("coupling_tol", "float", 1e-10, "iterative: relative tolerance of the coupled values",
                    minimum=0.0, applies_to=('iterative',)),
    AlgorithmOption("coupling_atol", "float", None, "iterative: absolute tolerance of the coupled values "
                    "(default: coupling_tol)", minimum=0.0, applies_to=('iterative',)),
    AlgorithmOption("coupling_max_iter", "int", 50, "iterative: iterations per step at most", minimum=1,
                    applies_to=('iterative',)),
    AlgorithmOption("coupling_update", "choice", "iqn-ils", "iterative: how the next iterate is formed",
                    choices=("fixed-point", "aitken", "iqn-ils"), applies_to=('iterative',)),
    AlgorithmOption("coupling_interpolation", "int", 0, "iterative: 0 inputs held at the end-of-step iterate "
                    "(order 1), 1 every coupled input held at the mean over the step of the line from its value at "
                    "the step's start to the iterate (trapezoidal, order 2; docs/coupling.md)", choices=(0, 1),
                    applies_to=('iterative',)),
    # adaptive and ecco: the defaults differ per algorithm (algorithms/adaptive.py, ecco.py) and the step limits are
    # checked against each other and the master step there (step_control.StepLimits), so no default here
    AlgorithmOption("step_rtol", "float", None, "adaptive: relative tolerance of the step's error estimate "
                    "(default 1e-4); ecco: of the energy residual (default 1e-4)", minimum=0.0,
                    applies_to=('adaptive', 'ecco')),
    AlgorithmOption("step_atol", "float", None, "adaptive, ecco: absolute tolerance (default: step_rtol)",
                    minimum=0.0, applies_to=('adaptive', 'ecco')),
    AlgorithmOption("min_step", "float", None, "adaptive, ecco: smallest step in seconds", positive=True,
                    applies_to=('adaptive', 'ecco')),
    AlgorithmOption("max_step", "float", None, "adaptive, ecco: largest step in seconds (default and at most: "
                    "the master step, which the steps end on)", positive=True, applies_to=('adaptive', 'ecco')),
    AlgorithmOption("initial_step", "float", None, "adaptive, ecco: first step in seconds", positive=True,
                    applies_to=('adaptive', 'ecco')),
    AlgorithmOption("error_estimate", "choice", None, "adaptive: local error from the extrapolated vs computed "
                    "coupled values (default: extrapolation) or from step doubling (docs/coupling.md)",
                    choices=("extrapolation", "doubling"), applies_to=('adaptive',)),
    AlgorithmOption("threads", "int", 1, "jacobi: threads that run the doSteps of a master step concurrently "
                    "(1: one after another; only doSteps that release the GIL overlap: native FMUs, the SITL "
                    "vehicle; results bit-identical; docs/coupling.md)", minimum=1, applies_to=('jacobi',)),
)}


def resolve_algorithm_options(options, from_ssd: dict, caller: str) -> dict:
    """Fill every algorithm setting of ``options`` (execution.Options) that the caller left at None: from the
    SSD settings annotation (``from_ssd``: name -> parsed value), else the default. Returns name -> source."""
    sources = {}
    for name, opt in ALGORITHM_OPTIONS.items():
        given = getattr(options, name, None)
        if given is not None:
            setattr(options, name, opt.parse(given, opt.flag))
            sources[name] = caller
        elif name in from_ssd:
            setattr(options, name, from_ssd[name])
            sources[name] = "SSD settings annotation"
        else:
            setattr(options, name, opt.default)
            sources[name] = "default"
    return sources
