"""The one harness that checks every accelerator against the reference it replaces (master/accel.py).

Each accelerator published under the ``cosim_master.accelerators`` entry point group generates its own cases
from a seeded random source; both implementations run on each case and must agree bit for bit on everything
the case observes (outputs and the whole final state; floats compared by their IEEE bits, see bitwise.py; equal
pickles say yes first, at a fifth of the cost, see _same_pickle).
A new accelerator is covered by publishing it: no test file of its own, no pinned internals.

``COSIM_MASTER_HARNESS_SEEDS`` widens the search (default 3 seeds per accelerator)."""
from __future__ import annotations

import os
import pickle
import random

import numpy as np
import pytest

from bitwise import bits
from master import accel

SEEDS = range(int(os.environ.get("COSIM_MASTER_HARNESS_SEEDS", "3")))
DECLARED = accel.declared()


def test_accelerators_are_declared_and_name_their_reference():
    assert DECLARED, "no accelerator is published under cosim_master.accelerators"
    for name, acc in DECLARED.items():
        assert isinstance(acc, accel.Accelerator), name
        assert acc.name == name
        module, _, qualname = acc.replaces.partition(":")
        obj = __import__(module, fromlist=["_"])
        for part in qualname.split("."):
            obj = getattr(obj, part)          # the reference exists under the name the accelerator gives
        assert callable(obj)


@pytest.mark.parametrize("name", sorted(DECLARED))
@pytest.mark.parametrize("seed", SEEDS)
def test_accelerator_equals_its_reference(name, seed):
    acc = DECLARED[name]
    impl, why = acc.load()
    if impl is None:
        pytest.skip(f"{name} is not available here: {why}")
    n = 0
    for i, case in enumerate(acc.cases(random.Random(f"{name}/{seed}"))):
        want = acc.reference(case)
        got = acc.accelerated(impl, case)
        assert _same_pickle(got, want) or bits(got) == bits(want), \
            f"{name}: case {i} of seed {seed} differs from {acc.replaces}"
        n += 1
    assert n > 0, f"{name} generated no case"


def _same_pickle(got, want) -> bool:
    """A quick yes that implies ``bits(got) == bits(want)``, at a fifth of its cost: pickle writes a float as its 8
    IEEE bytes, ints, bools, strings and the types of containers exactly, an array as its dtype, shape and bytes, a
    generator with its state and an object with its whole state (no state class defines ``__getstate__`` or
    ``__reduce__``).  Equal pickles are therefore equal bits; unequal ones (a shared object memoised on one side
    only, a set's order, an unpicklable value) prove nothing, and the comparison of ``bits`` decides."""
    try:
        return pickle.dumps(got, 5) == pickle.dumps(want, 5)
    except Exception:           # whatever does not pickle is compared by bits
        return False


def test_the_one_variable_switches_every_accelerator_off(monkeypatch):
    monkeypatch.setenv(accel.ENV, "1")
    for name, acc in DECLARED.items():
        impl, why = acc.load()
        assert impl is None and why, f"{name} still loads with {accel.ENV}=1"



@pytest.mark.parametrize("a, b", [
    (0.0, -0.0), (float("nan"), -float("nan")), (1, 1.0), (1, True), ("1", b"1"), ([1.0], (1.0,)),
    ({"x": 1.0, "y": 2.0}, {"y": 2.0, "x": 1.0}), (5e-324, 0.0), (1.0, 1.0 + 2.0 ** -52),
    (np.array([0.0]), np.array([-0.0])), (np.zeros(2), np.zeros(2, dtype=np.float32)),
    (np.zeros(2), np.zeros((1, 2))),
    (np.random.default_rng(1), np.random.default_rng(2)),
])
def test_the_quick_yes_never_hides_a_difference_that_bits_sees(a, b):
    """Pairs that ``==`` calls equal or near but ``bits`` tells apart: the pickle shortcut tells them apart too,
    and says yes to each value against a copy of itself."""
    assert bits(a) != bits(b) and not _same_pickle(a, b)
    for v in (a, b):
        assert _same_pickle(v, pickle.loads(pickle.dumps(v)))
