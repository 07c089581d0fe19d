"""The strategy's indexed mission parameters (uavsim/mission_encoding.py) and their limits."""
from __future__ import annotations

import pytest
import yaml
from build_script import load_shell

from master.errors import ScenarioError
from uavsim import mission_encoding as M
from uavstudy.scenario import load_scenario_yaml

TARGETS = [(1.5, 2.0), (-3.25, 4.0)]
ZONES = [[(100.0, 100.0), (110.0, 100.0), (110.0, 110.0)]]


def _strategy_fmu():
    return load_shell("UavStrategy")


def test_encode_decode_round_trip():
    values = M.encode(TARGETS, ZONES)
    assert values["n_targets"] == 2 and values["target_y_2"] == 4.0 and values["zone_1_n_vertices"] == 3
    get = {**dict.fromkeys((n for n, _ in M.parameter_names()), 0), **values}.__getitem__
    assert M.decode_targets(get) == TARGETS and M.decode_zones(get) == ZONES


def test_not_given_means_the_string_form():
    get = {"n_targets": M.NOT_GIVEN, "n_zones": M.NOT_GIVEN}.__getitem__
    assert M.decode_targets(get) is None and M.decode_zones(get) is None


@pytest.mark.parametrize("targets, zones, message", [
    ([(0.0, 0.0)] * 65, [], "65 targets (the strategy FMU takes 0..64)"),
    ([], [ZONES[0]] * 17, "17 zones (the strategy FMU takes at most 16)"),
    ([], [[(float(j), float(j * j)) for j in range(33)]], "zone 1 has 33 vertices (the strategy FMU takes 3..32"),
])
def test_encode_rejects_missions_beyond_the_limits(targets, zones, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        M.encode(targets, zones)


def test_fmu_indexed_form_wins_over_the_string_form():
    fmu = _strategy_fmu()
    fmu.targets, fmu.zones = "9,9;8,8;7,7", "0,0;1,0;1,1"
    for name, value in M.encode(TARGETS, ZONES).items():
        setattr(fmu, name, value)
    fmu.exit_initialization_mode()
    assert fmu._model.targets == TARGETS and fmu.targets_assigned == 2
    assert [list(p.exterior.coords)[:3] for p in fmu._model.zones.polys][0][0] == (100.0, 100.0)


def test_fmu_string_form_when_indexed_not_given():
    fmu = _strategy_fmu()
    fmu.targets = "9,9;8,8;7,7"
    fmu.exit_initialization_mode()
    assert fmu._model.targets == [(9.0, 9.0), (8.0, 8.0), (7.0, 7.0)] and not fmu._model.zones


def test_fmu_rejects_counts_beyond_the_limits():
    fmu = _strategy_fmu()
    fmu.n_targets = 65
    with pytest.raises(ValueError, match="n_targets = 65: the strategy FMU takes -1 \\(not given\\) or 0..64"):
        fmu.exit_initialization_mode()


def test_scenario_with_too_many_targets_is_rejected(tmp_path):
    targets = [[45.0 + 0.0005 * (k // 10), 7.0005 + 0.0005 * (k % 10)] for k in range(65)]
    path = tmp_path / "many.yaml"
    path.write_text(yaml.safe_dump({"name": "many", "base": [45.0, 7.0, 0.0], "n_uavs": 1, "strategy": "A",
                                    "targets": targets}))
    with pytest.raises(ScenarioError, match="65 targets, at most 64"):
        load_scenario_yaml(path)
