"""What the UAV shells remember between instances to start faster (uavsim/fmi.py ``UnitsMixin._plain``,
uavsim/zones_planning.py ``ZoneMap.records``) must be what they would compute afresh."""
from __future__ import annotations

import importlib.util
import random

from build_script import SRC

from uavsim import strategy as S


def _shell_class(name):
    spec = importlib.util.spec_from_file_location(f"caches_{name}", SRC / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return getattr(mod, name)


def _new(cls, name):
    return cls(instance_name=name, resources=str(SRC), visible=False)


def _fresh_plain(obj, names) -> bool:
    return all(a.__class__ is str and not hasattr(type(obj), a) for a in names)


def test_plain_names_remembered_per_class_answer_as_computed():
    rng = random.Random(3)
    for shell in ("UavDynamics", "UavStrategy", "UavBattery"):
        cls = _shell_class(shell)
        a, b = _new(cls, "a"), _new(cls, "b")
        names = [v.name for v in a.vars.values()]
        # the geodetic outputs of the dynamics are properties: a tuple holding one of them is not plain
        cases = [tuple(names), tuple(names[:3]), ("lat",), ("x", "lat"), ("do_step",), (None,)]
        cases += [tuple(rng.sample(names, min(len(names), 5))) for _ in range(20)]
        for case in cases:
            expected = _fresh_plain(a, case)
            assert a._plain(case) is expected, (shell, case)
            assert b._plain(case) is expected, (shell, case)      # the second instance: from the table
        assert cls._var_table.plain, shell
    assert _shell_class("UavDynamics")._plain.__qualname__.startswith("UnitsMixin")


def test_a_class_with_a_property_keeps_its_own_answer():
    dyn, strat = _shell_class("UavDynamics"), _shell_class("UavStrategy")
    d, s = _new(dyn, "d"), _new(strat, "s")
    assert s._plain(("x", "y")) is True
    assert d._plain(("x", "lat")) is False and s._plain(("x", "lat")) is True     # the strategy has no lat property


def test_raw_writers_of_start_values_store_the_parameters():
    cls = _shell_class("UavStrategy")
    s = _new(cls, "s")
    vrs = [vr for vr, v in s.vars.items() if v.name.startswith("target_x_")][:4]
    update, names = s.cosim_bind("set_raw", "Real", vrs)
    update(zip(names, [1.5, -0.0, 3.0, 4.0]))
    assert [getattr(s, n) for n in names] == [1.5, -0.0, 3.0, 4.0]


def _zones(rng, n):
    out = []
    for _ in range(n):
        cx, cy, r = rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(20, 80)
        out.append([(cx + r * dx, cy + r * dy) for dx, dy in ((-1, -1), (1, -1), (1.2, 0.5), (0, 1), (-1, 0.7))])
    return out


def test_zone_records_made_once_per_map_equal_each_zones_own():
    rng = random.Random(11)
    for n in (0, 1, 4):
        zones = _zones(rng, n)
        first = S.ZoneMap(zones, 5.0)
        expected = [v for poly in first.polys for v in S.zone_record(poly)]
        assert first.records() == expected
        assert first.records() is first.records()
        second = S.ZoneMap(zones, 5.0)            # the first is held: a map of its own, the same records
        assert second is not first and second.records() == expected


def test_a_strategy_packs_the_same_constants_from_the_remembered_records():
    zones = _zones(random.Random(4), 3)
    params = S.StrategyParams(targets=[(100.0, 50.0), (-80.0, 30.0)], zones=zones, uav_count=1)
    a, b = S.Strategy(params), S.Strategy(params)
    assert a.zones is not b.zones
    a.zones.records()                              # remembered before b packs its own
    fresh = [v for poly in b.zones.polys for v in S.zone_record(poly)]
    assert b.step_constants == a.step_constants
    assert b.step_constants[-8 * len(fresh):] == __import__("array").array("d", fresh).tobytes()
