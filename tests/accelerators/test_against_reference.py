"""The one harness that checks every accelerator against the reference it replaces (master/accel.py).

Each accelerator published under the ``cosim_master.accelerators`` entry point group generates its own cases
from a seeded random source; both implementations run on each case and must agree bit for bit on everything
the case observes (outputs and the whole final state; floats compared by their IEEE bits, see bitwise.py).
A new accelerator is covered by publishing it: no test file of its own, no pinned internals.

``COSIM_MASTER_HARNESS_SEEDS`` widens the search (default 3 seeds per accelerator)."""
from __future__ import annotations

import os
import random

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
        assert bits(got) == bits(want), f"{name}: case {i} of seed {seed} differs from {acc.replaces}"
        n += 1
    assert n > 0, f"{name} generated no case"


def test_the_one_variable_switches_every_accelerator_off(monkeypatch):
    monkeypatch.setenv(accel.ENV, "1")
    for name, acc in DECLARED.items():
        impl, why = acc.load()
        assert impl is None and why, f"{name} still loads with {accel.ENV}=1"
