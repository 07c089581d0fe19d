"""The test after every master step that all Real outputs are finite, as cheap as it can be.

The reference is :func:`numpy_check`: ``out.dot(zeros) != 0`` (NaN or an infinity times 0 is NaN, a finite value
times 0 is 0), one numpy call on a few tens of values; numpy's fixed cost per call made it a few per cent of a
campaign run's step loop. ``finite_ext.c`` runs the same test as a CPython extension function, built on first use
for the running interpreter (master/native_build.py). It is an accelerator (master/accel.py, declared below as
``FINITE_CHECK``): without a compiler or Python's headers, or with ``COSIM_MASTER_PURE_PYTHON=1``, the numpy test
runs. Both answer the same for every array (tests/accelerators/).
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from .. import accel
from ..native_build import compile_extension

SOURCE = Path(__file__).with_name("finite_ext.c")
FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared"]


@functools.cache
def extension():
    """(the module, None) or (None, why it cannot be built here)."""
    return compile_extension(SOURCE, "_finite_ext", "finite-check", FLAGS)


def numpy_check(out: np.ndarray, zeros: np.ndarray):
    """The reference: a callable of no argument, true when every value of ``out`` is finite."""
    dot = out.dot
    return lambda: not dot(zeros) != 0.0


def finite_check(out: np.ndarray, zeros: np.ndarray | None = None):
    """A callable of no argument, true when every value of ``out`` (a C-contiguous float64 array that is never
    reallocated, kept alive by its owner) is finite at the time of the call."""
    module = extension()[0] if accel.enabled() else None
    if module is None or not (out.dtype == np.float64 and out.flags.c_contiguous):
        return numpy_check(out, np.zeros(len(out)) if zeros is None else zeros)
    return functools.partial(module.all_finite, out.ctypes.data, out.size)


class FiniteCheck:
    """The C finiteness test as an accelerator of :func:`numpy_check`. A case is an array and the changes made to
    it one after another; both answer after each change (the test sees the array as it is at the time of the
    call), on NaNs of any payload, infinities, huge, tiny, subnormal and signed-zero values."""
    name = "master.finite-check"
    replaces = "master.algorithms.finite:numpy_check"
    AWKWARD = [0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
               -1.7976931348623157e308, 1e300, math.inf, -math.inf, math.nan]

    def load(self):
        if not accel.enabled():
            return None, f"{accel.ENV} is set"
        module, why = extension()
        return (module.all_finite, None) if module is not None else (None, why)

    def cases(self, rng):
        for _ in range(300):
            n = rng.randrange(0, 70)
            values = [rng.uniform(-1e6, 1e6) for _ in range(n)]
            changes = [(rng.randrange(n), self._awkward(rng)) for _ in range(rng.randrange(0, 4) if n else 0)]
            yield values, changes

    def _awkward(self, rng) -> float:
        if rng.random() < 0.2:      # a NaN with a payload and sign of its own
            bits = 0x7FF0000000000000 | rng.randrange(1, 1 << 52) | (rng.randrange(2) << 63)
            return float(np.array([bits], dtype=np.uint64).view(np.float64)[0])
        return rng.choice(self.AWKWARD)

    def _answers(self, case, make):
        values, changes = case
        a = np.array(values, dtype=np.float64)
        check = make(a)
        answers = [check()]
        with np.errstate(invalid="ignore", over="ignore"):
            for k, v in changes:
                a[k] = v
                answers.append(check())
        return answers

    def reference(self, case):
        return self._answers(case, lambda a: numpy_check(a, np.zeros(len(a))))

    def accelerated(self, impl, case):
        return self._answers(case, lambda a: functools.partial(impl, a.ctypes.data, a.size))


FINITE_CHECK = FiniteCheck()
