"""The instances of a pythonfmu shell class share one variable table (uavsim/fmi.py), yet each keeps its own values."""
from __future__ import annotations

import importlib.util
import tracemalloc

import pytest
from build_script import SRC
from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Causality
from pythonfmu.variables import Integer, Real

from uavsim import mission_encoding as M
from uavsim.fmi import StateMixin, UnitsMixin


def _shell_class(name):
    spec = importlib.util.spec_from_file_location(f"shared_{name}", SRC / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return getattr(mod, name)


def _new(cls, name):
    return cls(instance_name=name, resources=str(SRC), visible=False)


def _vr(slave, name):
    return next(vr for vr, v in slave.vars.items() if v.name == name)


def test_two_strategies_share_the_table_and_keep_their_own_parameters():
    cls = _shell_class("UavStrategy")
    a, b = _new(cls, "a"), _new(cls, "b")
    # the mission + the shell + strategy C's (uavsim/cooperative_fmi.py: 8 parameters, 4 x 15 message slots, 17 outputs)
    assert a.vars is b.vars and len(a.vars) == len(list(M.parameter_names())) + 41 + 85
    assert all(v.getter is None and v.setter is None for v in a.vars.values())   # nothing bound to one instance
    one, two = M.encode([(10.0, 20.0)], []), M.encode([(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)], [])
    for slave, values in ((a, one), (b, two)):
        ints = [(n, v) for n, v in values.items() if isinstance(v, int)]
        reals = [(n, v) for n, v in values.items() if isinstance(v, float)]
        slave.set_integer([_vr(slave, n) for n, _ in ints], [v for _, v in ints])
        slave.set_real([_vr(slave, n) for n, _ in reals], [v for _, v in reals])
    assert a.get_real([_vr(a, "target_x_1")]) == [10.0] and b.get_real([_vr(b, "target_x_1")]) == [1.0]
    assert a.get_integer([_vr(a, "n_targets")]) == [1] and b.get_integer([_vr(b, "n_targets")]) == [3]
    a.exit_initialization_mode()
    b.exit_initialization_mode()
    assert a._model.targets == [(10.0, 20.0)] and b._model.targets == [(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)]
    assert (a.targets_assigned, b.targets_assigned) == (1, 3)
    # each fast accessor is bound to its own instance
    read = [_vr(a, "targets_assigned")]
    assert a.cosim_bind("get", "Integer", read)() == [1] and b.cosim_bind("get", "Integer", read)() == [3]
    b.cosim_bind("set", "Real", [_vr(b, "x")])([7.5])
    assert (a.x, b.x) == (0.0, 7.5)


def test_raw_readers_are_shared_by_the_instances_of_a_class():
    # a master binds the same references of every UAV: the second instance gets the first one's attrgetter, which
    # reads whichever instance it is given; another type or other references get their own (or None)
    cls = _shell_class("UavDynamics")
    a, b = _new(cls, "a"), _new(cls, "b")
    for s, x in ((a, 1.5), (b, -2.0)):
        s.exit_initialization_mode()
        s.x, s.phase = x, 3 if x > 0 else 1
    reals = [_vr(a, "x"), _vr(a, "tilt"), _vr(a, "lat")]
    fetch, single = a.cosim_bind("get_raw", "Real", reals)
    assert b.cosim_bind("get_raw", "Real", reals) == (fetch, single) and not single
    assert fetch(a) == tuple(a.get_real(reals)) and fetch(b) == tuple(b.get_real(reals)) and fetch(a) != fetch(b)
    phase = [_vr(a, "phase")]
    one = b.cosim_bind("get_raw", "Integer", phase)
    assert one[1] and (one[0](a), one[0](b)) == (3, 1)
    assert a.cosim_bind("get_raw", "Real", phase) is None and b.cosim_bind("get_raw", "Real", phase) is None
    assert a.cosim_bind("get_raw", "Real", reals[:1])[0](b) == -2.0


def test_state_save_and_restore_with_a_shared_table():
    cls = _shell_class("UavDynamics")
    a, b = _new(cls, "a"), _new(cls, "b")
    for s in (a, b):
        s.exit_initialization_mode()
    a.set_integer([_vr(a, "cmd")], [1])                  # take off (after the pre-flight checks)
    saved = a._get_fmu_state()
    a.do_step(0.0, 10.0)
    after = a.get_real([_vr(a, "x"), _vr(a, "z")])
    a._set_fmu_state(saved)
    a.do_step(0.0, 10.0)
    assert a.get_real([_vr(a, "x"), _vr(a, "z")]) == after and after[1] > 0.0
    assert b.get_real([_vr(b, "z")]) == [0.0] and a.vars is b.vars          # the neighbour did not move


def test_a_later_instance_costs_its_values_not_a_variable_table():
    # pythonfmu builds ~1.2 kB of objects per variable and instance (a ScalarVariable with two dicts and two
    # closures): 1.5 MB for the strategy's 1211. Shared, an instance holds its ~1230 attributes: one dict
    # slot (~50 B with the index) per attribute, values shared until set, so well under 200 kB.
    cls = _shell_class("UavStrategy")
    _new(cls, "first")
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    later = [_new(cls, f"u{i}") for i in range(8)]
    per_instance = (tracemalloc.get_traced_memory()[0] - before) / len(later)
    tracemalloc.stop()
    assert per_instance < 200_000, per_instance


def test_instances_registering_differently_are_refused():
    class Odd(UnitsMixin, Fmi2Slave):
        made = 0

        def __init__(self, **kw):
            super().__init__(**kw)
            Odd.made += 1
            self.u = 0.0
            self.in_real("u" if Odd.made == 1 else "v", "m", "input")

        def do_step(self, t, h):
            return True

    _new(Odd, "first")
    with pytest.raises(RuntimeError, match="registers variable 0 as 'v', its first instance registered 'u'"):
        _new(Odd, "second")


def test_a_class_with_bound_accessors_keeps_per_instance_variables():
    # a custom getter is a closure over its instance: such a class cannot share, and works as pythonfmu's
    class Doubler(StateMixin, UnitsMixin, Fmi2Slave):
        def __init__(self, **kw):
            super().__init__(**kw)
            self.u = 0.0
            self.in_real("u", "m", "input")
            self.register_variable(Real("y", causality=Fmi2Causality.output, getter=lambda: 2.0 * self.u))
            self.k = 3
            self.register_variable(Integer("k", causality=Fmi2Causality.parameter))

        def do_step(self, t, h):
            return True

    a, b = _new(Doubler, "a"), _new(Doubler, "b")
    assert a.vars is not b.vars
    a.set_real([0], [1.5])
    b.set_real([0], [4.0])
    assert a.get_real([0, 1]) == [1.5, 3.0] and b.get_real([0, 1]) == [4.0, 8.0]
    with pytest.raises(TypeError, match="valueReference=2 is not of type Real"):
        a.get_real([0, 2])


def test_errors_of_a_shared_table_are_pythonfmus():
    # pythonfmu gives no setter to a variable whose attribute is computed (lat: a read-only property)
    cls = _shell_class("UavDynamics")
    s = _new(cls, "s")
    real = [vr for vr, v in s.vars.items() if isinstance(v, Real)]
    lat = _vr(s, "lat")
    with pytest.raises(TypeError, match=f"valueReference={lat} \\(lat\\) cannot be set"):
        s.set_real([lat], [1.0])
    with pytest.raises(TypeError, match="is not of type Integer"):
        s.set_integer(real[:1], [1])
    with pytest.raises(KeyError):
        s.get_real(real[:1] + [10 ** 6])
