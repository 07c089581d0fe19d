"""The finiteness test after every master step (master/algorithms/finite.py): the C extension function answers
as the numpy test it replaces (out.dot(zeros) != 0 means a NaN or an infinity) and as math.isfinite value by value,
on thousands of arrays with NaNs (of any payload), infinities, huge, tiny, subnormal and signed-zero values, and
it sees the array as it is at the time of the call."""
import math
import random

import numpy as np
import pytest

from master.algorithms import finite

AWKWARD = [0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
           -1.7976931348623157e308, 1e300, math.inf, -math.inf, math.nan]


def _nan_with_payload(rng):
    bits = 0x7FF0000000000000 | rng.randrange(1, 1 << 52) | (rng.randrange(2) << 63)
    return np.array([bits], dtype=np.uint64).view(np.float64)[0]


def _arrays(rng, count):
    for _ in range(count):
        n = rng.randrange(0, 70)
        a = np.array([rng.uniform(-1e6, 1e6) for _ in range(n)], dtype=np.float64)
        for _ in range(rng.randrange(0, 3) if n else 0):
            k = rng.randrange(n)
            a[k] = _nan_with_payload(rng) if rng.random() < 0.2 else rng.choice(AWKWARD)
        yield a


def test_extension_is_built():
    module, why = finite.extension()
    assert module is not None, why


def test_c_test_equals_numpy_and_isfinite():
    rng = random.Random(20261127)
    checked = nonfinite = 0
    for a in _arrays(rng, 5000):
        expected = all(math.isfinite(v) for v in a.tolist())
        c = finite.finite_check(a)
        twin = finite.numpy_check(a, np.zeros(len(a)))
        with np.errstate(invalid="ignore", over="ignore"):
            assert c() is expected and twin() is expected, a
        checked += 1
        nonfinite += not expected
    assert nonfinite > 500 and checked - nonfinite > 500      # both answers were exercised


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_each_position_and_the_current_values(value):
    a = np.ones(40)
    check = finite.finite_check(a)
    for k in range(len(a)):
        a[k] = value
        assert check() is False, k
        a[k] = 1e308            # large but finite: no overflow counts as non-finite
        assert check() is True, k


def test_pure_python_switch(monkeypatch):
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    finite.extension.cache_clear()
    try:
        a = np.array([1.0, math.inf])
        check = finite.finite_check(a)
        assert finite.extension()[0] is None
        with np.errstate(invalid="ignore"):
            assert check() is False
            a[1] = 2.0
            assert check() is True
    finally:
        finite.extension.cache_clear()
