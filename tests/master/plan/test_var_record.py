"""``plan.model.Var`` is a plain class, not the frozen dataclass it was (every run defines it, and Python 3.11
compiles a dataclass's methods from source in every process). That dataclass, declared as it was, is the
reference: the same arguments, repr, equality and hash, immutable, and ``Var.changed`` makes what
``dataclasses.replace`` made."""
from __future__ import annotations

import copy
import dataclasses
import inspect
import math
import pickle
import random

import pytest

from master.plan.model import Var


@dataclasses.dataclass(frozen=True)
class Reference:
    component: str
    name: str
    vr: int
    type: str
    fmi_type: str
    causality: str
    variability: str
    unit: str | None
    shape: tuple = ()
    index: int | None = None
    array: str | None = None
    start: object = None


def _pairs(n: int):
    rng = random.Random(5)
    for _ in range(n):
        args = [rng.choice(["a", "b.c"]), rng.choice(["x", "y[2]"]), rng.randint(0, 9), "Real", "Float64",
                rng.choice(["input", "output"]), "continuous", rng.choice([None, "m"])]
        kw = {k: rng.choice(choices) for k, choices in (("shape", [(), (3,)]), ("index", [None, 0, 2]),
                                                         ("array", [None, "y"]), ("start", [None, 1.5, (1.0, 2.0)]))
              if rng.random() < 0.5}
        yield Var(*args, **kw), Reference(*args, **kw)


def test_the_constructor_takes_what_the_dataclass_took():
    assert not dataclasses.is_dataclass(Var)
    ours, ref = inspect.signature(Var).parameters.values(), inspect.signature(Reference).parameters.values()
    assert [(p.name, p.kind, p.default) for p in ours] == [(p.name, p.kind, p.default) for p in ref]
    for v, r in _pairs(100):
        assert repr(v) == repr(r).replace("Reference(", "Var(")
        assert [getattr(v, f.name) for f in dataclasses.fields(Reference)] == list(dataclasses.astuple(r))
    with pytest.raises(TypeError):
        Var("a", "x", 1, "Real", "Float64", "input", "continuous")      # unit has no default
    with pytest.raises(TypeError):
        Var("a", "x", 1, "Real", "Float64", "input", "continuous", None, (), None, None, None, "one too many")


def test_equal_as_the_dataclass_was_and_hashed_alike():
    pairs = list(_pairs(200))
    for v, r in pairs:
        for w, s in pairs:
            assert (v == w) == (r == s) and (v != w) == (r != s)
        assert hash(v) == hash(r)              # both hash the tuple of the fields
        assert v != r and v in {v: 1}
    # a NaN start: the same object is equal (identity first), a copy of it is not, in both
    args = ("a", "x", 1, "Real", "Float64", "input", "continuous", None, (), None, None, math.nan)
    v, r = Var(*args), Reference(*args)
    assert (v == v) == (r == r) is True
    assert (v == pickle.loads(pickle.dumps(v))) == (r == pickle.loads(pickle.dumps(r))) is False


def test_immutable_as_the_frozen_dataclass_was():
    v = Var("a", "x", 1, "Real", "Float64", "input", "continuous", None)
    for name in ("component", "start", "not_a_field"):
        with pytest.raises(dataclasses.FrozenInstanceError, match=f"cannot assign to field '{name}'"):
            setattr(v, name, 2)
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot delete field 'name'"):
        del v.name
    assert v.component == "a" and v.name == "x"
    assert copy.copy(v) == v and copy.deepcopy(v) == v and pickle.loads(pickle.dumps(v)) == v


def test_changed_is_what_dataclasses_replace_made():
    for v, r in _pairs(100):
        for changes in ({"shape": (2,), "start": [1, 2]}, {"name": "y[1]", "index": 0, "array": "y"},
                        {"shape": (), "index": None}, {}):
            c, d = v.changed(**changes), dataclasses.replace(r, **changes)
            assert repr(c) == repr(d).replace("Reference(", "Var(") and type(c) is Var and c is not v
    with pytest.raises(TypeError):
        v.changed(no_such_field=1)
