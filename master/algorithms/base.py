"""The algorithm interface: how one master step from t to t+h is carried out.

An algorithm sees only the Runtime (slaves, buffers, transfer and bound FMI operations, active and
multi-rate bookkeeping); parsing, initialization and recording never depend on it. A new algorithm
subclasses Algorithm, implements ``prepare`` (and ``step`` if it is not a fixed sequence of calls that
``compiled.compile_step`` can express), and registers itself with ``@ALGORITHMS.register("name")`` in its own
module of this folder.
"""
from __future__ import annotations

from ..errors import CosimError


class Algorithm:
    name = "base"
    gauss_seidel = False
    info: dict = {}          # facts for run.json; an algorithm with facts sets its own dict in stepping_order
    extrapolation = 0        # polynomial order of the coupled inputs (extrapolation.py); 0: held, as read
    honours_extrapolation = True    # a fixed-step algorithm whose inputs come from earlier outputs
    honours_per_output_extrapolation = True     # ... with an order per coupled output (extrapolation_for)
    honours_interpolation = False   # inputs produced earlier in the same step interpolated (gs_interpolation.py)
    extrapolation_for: dict = {}    # output name -> order, overriding ``extrapolation`` (per_output_orders)
    interpolation = 0               # Gauss-Seidel: samples besides the new one that known inputs are interpolated with
    honours_input_derivatives = False   # the extrapolation polynomial given as input derivatives (Jacobi)
    input_derivatives = 0
    honours_threads = False         # the doSteps of a step are independent and may run concurrently (parallel.py)
    threads = 1
    # what an algebraic loop means under this algorithm, completing "initialization iterates it until the values
    # settle; ..." in ``inspect`` (each algorithm knows best how it treats a loop)
    loop_treatment = "every input is read from the previous step, so the loop only delays values by a step"

    def configure(self, options) -> None:
        """The run's options (execution.Options), before ``prepare``: an algorithm takes the ones it uses."""
        k = int(getattr(options, "extrapolation", 0) or 0)
        if k and not self.honours_extrapolation:
            raise CosimError(f"--extrapolation does not apply to the {self.name} algorithm (only to fixed-step "
                             "algorithms that feed inputs from earlier outputs: jacobi, gauss-seidel)",
                             element="--extrapolation")
        if k not in (0, 1, 2):
            raise CosimError(f"--extrapolation must be 0, 1 or 2, not {k}", element="--extrapolation")
        self.extrapolation = k
        self.extrapolation_for = dict(getattr(options, "extrapolation_for", None) or {})
        if self.extrapolation_for and not (self.honours_extrapolation and self.honours_per_output_extrapolation):
            raise CosimError(f"per-output extrapolation orders do not apply to the {self.name} algorithm (jacobi, "
                             "gauss-seidel; adaptive takes the global --extrapolation only)", element="--extrapolate")
        self.interpolation = int(getattr(options, "gs_interpolation", 0) or 0)
        if self.interpolation and not self.honours_interpolation:
            raise CosimError(f"applies to gauss-seidel only, not to {self.name}",
                             element="--gs-interpolation")
        self.input_derivatives = int(getattr(options, "input_derivatives", 0) or 0)
        if self.input_derivatives:
            if not self.honours_input_derivatives:
                raise CosimError(f"applies to jacobi only, not to {self.name}", element="--input-derivatives")
            if self.input_derivatives == 1 and not (self.extrapolation or any(self.extrapolation_for.values())):
                raise CosimError("1 needs --extrapolation 1 or 2: the derivatives given are those of the "
                                 "extrapolation polynomial (2 also takes the producers' output derivatives)",
                                 element="--input-derivatives")
        self.threads = int(getattr(options, "threads", 1) or 1)
        if self.threads < 1:
            raise CosimError(f"must be at least 1, got {self.threads}", element="--threads")
        if self.threads > 1 and not self.honours_threads:
            raise CosimError(f"applies to jacobi only (its doSteps within a step are independent), not to "
                             f"{self.name}", element="--threads")

    @property
    def feeds_inputs(self) -> bool:
        """Whether the step needs the extrapolation wrapper (never for default runs: they stay the compiled
        step itself, bit for bit)."""
        return bool(self.extrapolation or any(self.extrapolation_for.values()) or self.interpolation
                    or self.input_derivatives)

    def prepare(self, rt, plan, h: float) -> dict:
        """Called once after initialization; returns facts worth recording in run.json."""
        self.rt = rt
        self.h = h
        self.order = self.stepping_order(rt, plan)
        if self.feeds_inputs:
            from .extrapolation import InputExtrapolation
            self._extrapolator = InputExtrapolation(rt, plan, self.extrapolation, self.extrapolation_for,
                                                    keep=self.interpolation,
                                                    derivatives_step=h if self.input_derivatives else None,
                                                    slopes=self.input_derivatives == 2)
            self.info = {**self.info, "extrapolation": self._extrapolator.describe()}
        if self.threads > 1:
            from .parallel import StepPool
            self._pool = StepPool(self.threads)
            self.info = {**self.info, "threads": self.threads}
        self._build()
        return self.info

    def stepping_order(self, rt, plan) -> list[int]:
        return list(range(len(rt.slaves)))

    @property
    def current_step(self):
        """The step function the next ``step`` calls (None before ``prepare``): a supervisor maps a crash inside
        it to a line of its source, and notices a rebuild by its identity."""
        return getattr(self, "_step", None)

    def _build(self):
        self._step = self._compile(self.h)
        self.rt.changed = False

    def _compile(self, h: float, lengths: dict | None = None):
        step = self._sweep(h, lengths)
        if self.feeds_inputs:      # only then: the default step stays the compiled function itself
            step = self._extrapolator.around(step, h / self.h)
        return step

    def _sweep(self, h: float, lengths: dict | None = None):
        if self.threads > 1 and not lengths:
            from .parallel import compile_parallel_step
            return compile_parallel_step(self.rt, self.order, h, self._pool)
        from .compiled import compile_step
        return compile_step(self.rt, self.order, h, self.gauss_seidel, lengths)

    def step(self, n: int, t: float) -> None:
        if self.rt.changed:      # a monitor took a component out: step the others only
            self._build()
        self._step(n, t)

    def step_sized(self, n: int, t: float, h: float, lengths: dict | None = None) -> None:
        """One step of another length than the master step (the shorter last step of an interval that is not
        a whole number of steps); ``lengths``: component index -> the length of its doStep in this step, for
        components on a step multiple whose last macro step starts here."""
        if self.rt.changed:
            self._build()
        self._compile(h, lengths)(n, t)

    def finish(self, out_dir) -> dict:
        """Called once when the run closes (also after a failure): files of its own in ``out_dir`` (None: the
        run keeps its results in memory); returns facts to add to run.json's ``algorithm_info``."""
        if self.threads > 1:
            self._pool.close()
        return {}
