"""tests/bitwise.py, the comparison of the accelerator harness and of the C steps' tests: equal exactly when bit
for bit equal, whichever path (plain value, float inside a list, slotted object) a value takes."""
import numpy as np

from bitwise import bits


class _Slotted:
    __slots__ = ("a", "b")

    def __init__(self, a, b):
        self.a, self.b = a, b


def test_the_sign_of_zero_the_nan_and_the_last_bit_count_at_every_depth():
    nan = float("nan")
    for wrap in (lambda x: x, lambda x: [x], lambda x: (1, [x]), lambda x: {"k": x}, lambda x: _Slotted(0, x)):
        assert bits(wrap(0.0)) != bits(wrap(-0.0))
        assert bits(wrap(nan)) == bits(wrap(float("nan")))            # a NaN equals itself
        assert bits(wrap(1.0)) != bits(wrap(np.nextafter(1.0, 2.0).item()))
        assert bits(wrap(0.1 + 0.2)) == bits(wrap(0.30000000000000004))


def test_types_are_told_apart():
    assert len({bits(x) for x in (1, True, 1.0, "1", None, (1,), [1])}) == 7
    assert bits([1.0, 2]) != bits([1.0, 2.0]) and bits((1.0,)) != bits([1.0])
    assert bits(_Slotted(1.0, None)) != bits(_Slotted(1.0, 0))


def test_arrays_and_random_generators_by_their_bytes_and_state():
    assert bits(np.array([0.0])) != bits(np.array([-0.0]))
    assert bits(np.zeros(2, dtype=np.float32)) != bits(np.zeros(2))
    g, h = np.random.default_rng(5), np.random.default_rng(5)
    assert bits(g) == bits(h)
    g.random()
    assert bits(g) != bits(h)
