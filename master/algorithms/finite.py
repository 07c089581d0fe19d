"""The test after every master step that all Real outputs are finite, as cheap as it can be.

``out.dot(zeros) != 0`` (NaN or an infinity times 0 is NaN, a finite value times 0 is 0) is one numpy call on a
few tens of values, and numpy's fixed cost per call made it a few per cent of a campaign run's step loop.
``finite_ext.c`` runs the same test as a CPython extension function, built on first use for the running
interpreter (master/native_build.py); without a compiler or Python's headers, or with ``COSIM_MASTER_PURE_PYTHON``
set, the numpy test runs. Both answer the same for every array.
"""
from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from ..native_build import compile_extension

SOURCE = Path(__file__).with_name("finite_ext.c")
FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared"]


def disabled() -> bool:
    return os.environ.get("COSIM_MASTER_PURE_PYTHON", "") not in ("", "0")


@functools.cache
def extension():
    """(the module, None) or (None, why it is not available)."""
    if disabled():
        return None, "COSIM_MASTER_PURE_PYTHON is set"
    return compile_extension(SOURCE, "_finite_ext", "finite-check", FLAGS)


def numpy_check(out: np.ndarray, zeros: np.ndarray):
    """The numpy twin: a callable of no argument, true when every value of ``out`` is finite."""
    dot = out.dot
    return lambda: not dot(zeros) != 0.0


def finite_check(out: np.ndarray, zeros: np.ndarray | None = None):
    """A callable of no argument, true when every value of ``out`` (a C-contiguous float64 array that is never
    reallocated, kept alive by its owner) is finite at the time of the call."""
    module, _ = extension()
    if module is None or not (out.dtype == np.float64 and out.flags.c_contiguous):
        return numpy_check(out, np.zeros(len(out)) if zeros is None else zeros)
    return functools.partial(module.all_finite, out.ctypes.data, out.size)
