"""Random layouts are drawn once per process (uavstudy.layout._random_area) and shared by later runs: the shared
value must equal a fresh draw whatever was drawn before, and no caller may change it for the next one."""
from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np
import pytest

from uavstudy import layout
from uavstudy.layout import random_targets, random_zones, realize
from uavstudy.scenario import load_scenario_yaml

ROOT = Path(__file__).resolve().parents[2]


def _scenario(seed: int, n_targets: int = 24, n_zones: int = 4, n_uavs: int = 2, area_scale: float = 1.0):
    base = load_scenario_yaml(ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml")
    return dataclasses.replace(base, layout="random", layout_seed=seed, n_uavs=n_uavs, area_scale=area_scale,
                               targets=list(base.targets)[:n_targets], zones=(list(base.zones) * 3)[:n_zones])


def _fresh(seed: int, n_targets: int, n_zones: int, n_uavs: int, area_scale: float):
    """The layout drawn straight from the public draw functions (no cache), as realize documents it."""
    s_t, s_z, s_o = np.random.SeedSequence(seed).spawn(3)
    t = np.round(random_targets(np.random.default_rng(s_t), n_targets), 3)
    z = random_zones(np.random.default_rng(s_z), n_zones, t)
    order = tuple(int(k) for k in np.random.default_rng(s_o).permutation(n_uavs))
    return (t * area_scale).tolist(), [(q["name"], (q["polygon"] * area_scale).tolist()) for q in z], order


def _plain(lay):
    return lay.targets.tolist(), [(z["name"], z["polygon"].tolist()) for z in lay.zones], lay.order


CASES = [(7, 24, 4, 1, 1.0), (7, 24, 4, 4, 1.0), (7, 24, 0, 3, 1.0), (7, 12, 4, 2, 2.0), (8, 24, 4, 2, 1.0),
         (8, 24, 6, 2, 0.5)]


@pytest.mark.parametrize("order", [CASES, CASES[::-1], CASES[2:] + CASES[:2]])
def test_cached_layouts_equal_fresh_draws_in_any_order(order):
    layout._random_area.cache_clear()
    for case in order:
        for _ in range(2):          # the second call comes from the cache
            assert _plain(realize(_scenario(*case))) == _fresh(*case)
    # fleet size, strategy or wind never draw the area again: one draw per (seed, targets, zones)
    assert layout._random_area.cache_info().currsize == len({c[:3] for c in order})


def test_the_draw_is_the_one_the_shipped_campaigns_were_run_with():
    # sha256 of the targets and zones drawn by the code before the cache (commit cda6aeb)
    expected = {11: "f790d9e37b5963e4757173f1b0b2d66c01bb80a7e8c08ce572944a92aaa7f601",
                2021: "29e9bcc40e8b7c445d2c87fb3a5976ed4934aa55b36e86b181f81cb648884f22"}
    for seed, digest in expected.items():
        t, z, _ = _plain(realize(_scenario(seed)))
        assert hashlib.sha256(repr([t, z]).encode()).hexdigest() == digest


def test_a_caller_cannot_change_the_layout_of_the_next_run():
    layout._random_area.cache_clear()
    scn = _scenario(5)
    first = realize(scn)
    before = _plain(first)
    with pytest.raises(ValueError):
        first.targets[0, 0] = 1.0
    with pytest.raises(ValueError):
        first.zones[0]["polygon"][0, 0] = 1.0
    first.zones[0]["polygon"] = np.zeros((4, 2))
    first.zones[0]["name"] = "changed"
    first.zones.append({"name": "extra", "polygon": np.zeros((4, 2))})
    again = realize(scn)
    assert _plain(again) == before
    assert again.zones is not first.zones
