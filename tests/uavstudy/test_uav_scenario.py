"""Tests of uavstudy.scenario: YAML loading, validation messages, ENU, paper import."""
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from master.errors import ScenarioError
from uavstudy.scenario import (WindConfig, dump_scenario_yaml, load_paper_config,
                                 load_scenario_yaml, scenario_to_dict)
from uavsim.geodesy import enu_from_geodetic, geodetic_from_enu

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "ssp" / "scenarios"
PAPER = ROOT / "ssp" / "paper_config"

BASE = (45.0, 7.0, 250.0)


def minimal(**over):
    # targets ~111 m north and ~79 m east of the base
    d = {"name": "t", "base": [45.0, 7.0, 250.0], "n_uavs": 2, "strategy": "A",
         "targets": [[45.001, 7.0], [45.0, 7.001]]}
    d.update(over)
    return d


def write(tmp_path, data, name="s.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return p


# ------------------------------------------------------------------ loading
def test_minimal_defaults(tmp_path):
    s = load_scenario_yaml(write(tmp_path, minimal()))
    assert s.base == BASE and s.n_uavs == 2 and s.strategy == "A"
    assert s.targets == [(45.001, 7.0), (45.0, 7.001)]
    assert s.assignment == "equal" and s.zones == [] and s.algorithm == "jacobi"
    assert s.impact_diameter == 2.6 and s.lookahead == 2.0
    assert s.wind == WindConfig()
    assert s.wind.intensities == {"weak": 3.0, "moderate": 6.0, "strong": 9.0}


def test_full_fields_and_base_mapping(tmp_path):
    d = minimal(base={"lat": 45.0, "lon": 7.0, "alt": 250.0}, takeoff_altitude=15, assignment="spatial",
                zones=[{"name": "z", "polygon": [[45.0005, 7.0005], [45.0005, 7.0006], [45.0006, 7.0006]]}],
                wind={"probability": 0.15, "intensities": {"strong": 12}, "direction_deg": 270,
                      "decision_interval": 2.0, "turbulence": True, "gusts": False},
                seed=9, step=0.05, stop_time=600, impact_diameter=3.0, lookahead=5.0,
                algorithm="gauss-seidel")
    s = load_scenario_yaml(write(tmp_path, d))
    assert s.base == BASE and s.takeoff_altitude == 15.0 and s.assignment == "spatial"
    assert s.zones == [{"name": "z", "polygon": [(45.0005, 7.0005), (45.0005, 7.0006), (45.0006, 7.0006)]}]
    assert s.wind == WindConfig(0.15, {"weak": 3.0, "moderate": 6.0, "strong": 12.0}, 270.0, 2.0, True, False)
    assert (s.seed, s.step, s.stop_time, s.impact_diameter, s.lookahead, s.algorithm) == \
        (9, 0.05, 600.0, 3.0, 5.0, "gauss-seidel")


def test_dump_round_trip(tmp_path):
    s = load_scenario_yaml(SCEN / "paper_area_zones.yaml")
    dump_scenario_yaml(s, tmp_path / "x.yaml", header="copy")
    assert load_scenario_yaml(tmp_path / "x.yaml") == s
    assert scenario_to_dict(s)["base"] == {"lat": s.base[0], "lon": s.base[1], "alt": s.base[2]}


def test_zone_planning_reaches_every_strategy(tmp_path):
    # zone_planning (default true) becomes the strategy FMUs' zone_planning parameter, so a campaign can
    # switch to the paper's late detection with one key
    from master.inspect_scenario import inspect
    from uavstudy.build import build_scenario
    for value, expect in ((None, True), (False, False)):
        data = minimal(n_uavs=2) if value is None else minimal(n_uavs=2, zone_planning=value)
        s = load_scenario_yaml(write(tmp_path, data, name=f"zp_{value}.yaml"))
        assert s.zone_planning is expect
        assert load_scenario_yaml(write(tmp_path, scenario_to_dict(s), name="again.yaml")) == s
        info = inspect(build_scenario(tmp_path / f"zp_{value}.yaml", tmp_path / f"zp_{value}.ssp"))
        got = {p["variable"]: p["value"] for p in info["parameters"] if p["variable"].endswith(".zone_planning")}
        assert got == {"uav1_strat.zone_planning": expect, "uav2_strat.zone_planning": expect}


# --------------------------------------------------------------- validation
BAD = [
    (minimal(n_uavs=0), "n_uavs: must be >= 1, got 0"),
    (minimal(n_uavs=1.5), "n_uavs: expected an integer, got 1.5"),
    (minimal(n_uavs=True), "n_uavs: expected an integer, got True"),
    (minimal(strategy="D"), "strategy: must be one of A, B, C, got 'D'"),
    (minimal(assignment="random"), "assignment: must be one of equal, spatial, got 'random'"),
    (minimal(algorithm="rk4"), "algorithm: must be one of {algorithms}, got 'rk4'"),
    (minimal(name=""), "name: expected a non-empty string, got ''"),
    (minimal(base=[45.0, 7.0]), "base: expected [lat, lon, alt] or {lat, lon, alt}, got [45.0, 7.0]"),
    (minimal(base=[95.0, 7.0, 0]), "base.lat: must be <= 90, got 95"),
    (minimal(base={"lat": 45, "lon": 7, "height": 3}), "base.height: unknown field (expected one of lat, lon, alt)"),
    (minimal(base=[45.0, "x", 0]), "base.lon: expected a number, got 'x'"),
    (minimal(takeoff_altitude=0), "takeoff_altitude: must be > 0, got 0"),
    (minimal(targets=[]), "targets: expected a non-empty list of [lat, lon]"),
    (minimal(targets=[[45.001, 7.0], [45.0]]), "targets[1]: expected [lat, lon], got [45.0]"),
    (minimal(targets=[[45.001, 7.0], [45.0, 200]]), "targets[1].lon: must be <= 180, got 200"),
    (minimal(targets=[[45.001, 7.0], [46.0, 7.0]]), "targets[1]: 111.1 km from the base (max 50 km)"),
    (minimal(wind={"probability": 1.5}), "wind.probability: must be <= 1, got 1.5"),
    (minimal(wind={"speed": 3}), "wind.speed: unknown field (expected one of probability, intensities, "
                                 "direction_deg, decision_interval, turbulence, gusts, shared, effect)"),
    (minimal(wind={"intensities": {"weak": -1}}), "wind.intensities.weak: must be >= 0, got -1"),
    (minimal(wind={"intensities": {"calm": 1}}), "wind.intensities.calm: unknown field (expected one of weak, moderate, strong)"),
    (minimal(wind={"intensities": {"weak": 7}}), "wind.intensities: speeds must satisfy weak <= moderate <= strong, got 7, 6, 9"),
    (minimal(wind={"direction_deg": 360}), "wind.direction_deg: must be < 360, got 360"),
    (minimal(wind={"decision_interval": 0}), "wind.decision_interval: must be > 0, got 0"),
    (minimal(wind={"decision_interval": 0.01}), "wind.decision_interval: must be >= step (0.1), got 0.01"),
    (minimal(wind={"gusts": "yes"}), "wind.gusts: expected true or false, got 'yes'"),
    (minimal(wind=[1]), "wind: expected a mapping, got list"),
    (minimal(seed=-1), "seed: must be >= 0, got -1"),
    (minimal(step=0), "step: must be > 0, got 0"),
    (minimal(step=1.0, stop_time=0.5), "stop_time: must be >= step (1), got 0.5"),
    (minimal(impact_diameter=-2.6), "impact_diameter: must be > 0, got -2.6"),
    (minimal(lookahead=-1), "lookahead: must be >= 0, got -1"),
    (minimal(stop_time=float("nan")), "stop_time: must be finite, got nan"),
    (minimal(colour="red"), "colour: unknown field (expected one of name, base, n_uavs, strategy, targets, "
                            "takeoff_altitude, assignment, zones, wind, seed, step, stop_time, "
                            "impact_diameter, lookahead, algorithm, end_when_all_landed, zone_planning, "
                            "algorithm_options, rules, cruise_speed, max_accel, layout, layout_seed, area_scale, "
                            "takeoff, takeoff_interval, battery_capacity, "
                            "vehicle, sitl, comm)"),
    (minimal(zone_planning="late"), "zone_planning: expected true or false, got 'late'"),
    ({k: v for k, v in minimal().items() if k != "strategy"}, "strategy: missing required field"),
    (minimal(zones={"a": 1}), "zones: expected a list of {name, polygon}"),
    (minimal(zones=[{"name": "z"}]), "zones[0].polygon: missing required field"),
    (minimal(zones=[{"name": "z", "polygon": [[45, 7], [45, 7.1]]}]),
     "zones[0].polygon: expected a list of at least 3 [lat, lon] vertices"),
    (minimal(zones=[{"polygon": [[45.0005, 7.0005], [45.0005, 7.0006], [45.0006, 7.0006]], "h": 3}]),
     "zones[0].h: unknown field (expected one of name, polygon)"),
    # bow-tie
    (minimal(zones=[{"name": "z", "polygon": [[45.0005, 7.0005], [45.0006, 7.0006], [45.0005, 7.0006],
                                              [45.0006, 7.0005]]}]),
     "zones[0].polygon: invalid polygon (Self-intersection[7.00055 45.00055])"),
    (minimal(zones=[{"name": "z", "polygon": [[44.999, 6.999], [44.999, 7.0005], [45.0005, 7.0005]]}]),
     "zones[0].polygon: covers the base"),
    (minimal(zones=[{"name": "z", "polygon": [[45.0009, 6.9999], [45.0009, 7.0001], [45.0011, 7.0001],
                                              [45.0011, 6.9999]]}]),
     "zones[0].polygon: covers target 0 (a target in a restricted zone cannot be visited)"),
    (minimal(zones=[{"name": "z", "polygon": [[45.0005, 7.0005], [45.0005, 7.0006], [45.0006, 7.0006]]},
                    {"name": "z", "polygon": [[45.0004, 7.0005], [45.0004, 7.0006], [45.0003, 7.0006]]}]),
     "zones[1].name: duplicate zone name 'z'"),
    ([1, 2], "(top level): expected a mapping of scenario fields, got list"),
]


@pytest.mark.parametrize("data,msg", BAD, ids=[m.split(":")[0] + str(k) for k, (_, m) in enumerate(BAD)])
def test_validation_messages(tmp_path, data, msg):
    p = write(tmp_path, data)
    with pytest.raises(ScenarioError) as ei:
        load_scenario_yaml(p)
    text = str(ei.value)
    if "Self-intersection" in msg:      # coordinates of the crossing are ENU metres
        assert text.startswith(f"{p}: zones[0].polygon: invalid polygon (Self-intersection")
    else:
        from master.algorithms import ALGORITHMS        # the registered ones (other tests register more)
        assert text == f"{p}: {msg}".replace("{algorithms}", ", ".join(ALGORITHMS.names()))
    assert "\n" not in text


def test_yaml_syntax_and_missing_file(tmp_path):
    p = write(tmp_path, "name: [unclosed\n")
    with pytest.raises(ScenarioError) as ei:
        load_scenario_yaml(p)
    assert str(ei.value).startswith(f"{p}: line ") and "invalid YAML" in str(ei.value)
    assert "\n" not in str(ei.value)
    with pytest.raises(ScenarioError) as ei:
        load_scenario_yaml(tmp_path / "nope.yaml")
    assert str(ei.value).startswith(f"{tmp_path / 'nope.yaml'}: file: cannot read")


# ---------------------------------------------------------------------- ENU
def test_targets_and_zones_enu(tmp_path):
    s = load_scenario_yaml(write(tmp_path, minimal(zones=[
        {"name": "z", "polygon": [[45.0005, 7.0005], [45.0005, 7.0006], [45.0006, 7.0006]]}])))
    t = s.targets_enu()
    assert t.shape == (2, 2)
    # targets are evaluated at the base altitude h = 250 m, so arcs scale by (R + h)
    # 0.001 deg of latitude at 45 deg: (M(45) + h) * pi/180 * 1e-3 = 111.137 m north
    M, N, h = 6367381.8, 6388838.3, 250.0
    assert t[0] == pytest.approx([0.0, (M + h) * np.pi / 180e3], abs=2e-3)
    # 0.001 deg of longitude: (N(45) + h) cos(45) * pi/180 * 1e-3 = 78.850 m east
    assert t[1] == pytest.approx([(N + h) * np.sqrt(0.5) * np.pi / 180e3, 0.0], abs=2e-3)
    (z,) = s.zones_enu()
    assert z["name"] == "z" and z["polygon"].shape == (3, 2)
    e, n, _ = enu_from_geodetic(45.0006, 7.0006, 250.0, *BASE)
    assert z["polygon"][2] == pytest.approx([float(e), float(n)])
    lat, lon, _ = geodetic_from_enu(t[:, 0], t[:, 1], 0.0, *BASE)
    assert np.allclose(np.column_stack((lat, lon)), s.targets, atol=1e-10)


def test_paper_area_scenarios():
    free = load_scenario_yaml(SCEN / "paper_area.yaml")
    zon = load_scenario_yaml(SCEN / "paper_area_zones.yaml")
    assert len(free.targets) == 24 and free.zones == []
    assert zon.targets == free.targets and zon.base == free.base
    assert 3 <= len(zon.zones) <= 4
    t = free.targets_enu()
    assert np.abs(t).max() <= 600.0                       # +-600 m square about the base
    d = np.hypot(*(t[:, None, :] - t[None, :, :]).transpose(2, 0, 1))
    assert d[np.triu_indices(24, 1)].min() >= 59.9
    # no zone covers (or comes within 30 m of) a target or the base
    import shapely
    for z in zon.zones_enu():
        poly = shapely.Polygon(z["polygon"])
        assert shapely.distance(poly, shapely.points(t)).min() > 30.0
        assert shapely.distance(poly, shapely.Point(0, 0)) > 30.0


# ------------------------------------------------------------- paper format
def test_paper_config_equals_yaml():
    assert load_paper_config(PAPER) == load_scenario_yaml(SCEN / "paper_area_zones.yaml")


def test_paper_config_without_zones_is_free_area(tmp_path):
    d = tmp_path / "cfg"
    shutil.copytree(PAPER, d)
    (d / "restrictedAreas.txt").unlink()
    text = (d / "init.properties").read_text().replace("name=paper_area_zones", "name=paper_area")
    (d / "init.properties").write_text(text)
    assert load_paper_config(d) == load_scenario_yaml(SCEN / "paper_area.yaml")


def make_cfg(tmp_path, props, targets, zones=None):
    d = tmp_path / "cfg"
    d.mkdir(exist_ok=True)
    (d / "init.properties").write_text(props)
    (d / "targets.txt").write_text(targets)
    if zones is not None:
        (d / "restrictedAreas.txt").write_text(zones)
    return d


DOC_PROPS = """# init.properties
name=demo
base.latitude=-7.2750
base.longitude=-35.9650
base.altitude=540.0
takeoff.altitude=20
uav.count=2
strategy=B
wind.probability=0.05
seed=3
"""
DOC_TARGETS = """# targets.txt: base first, then targets
-7.2750,-35.9650
-7.2774982,-35.9635114
-7.2802458,-35.9699874
"""
DOC_ZONES = """# restrictedAreas.txt
hospital: -7.2763372,-35.9643625;-7.2753499,-35.9635811;-7.2750289,-35.9639868;-7.2760163,-35.9647682
-7.2730868,-35.9681112;-7.272114,-35.9679229;-7.2720009,-35.9685114
"""


def test_doc_example(tmp_path):
    s = load_paper_config(make_cfg(tmp_path, DOC_PROPS, DOC_TARGETS, DOC_ZONES))
    assert s.name == "demo" and s.base == (-7.275, -35.965, 540.0) and s.n_uavs == 2
    assert s.strategy == "B" and s.wind.probability == 0.05 and s.seed == 3
    assert s.targets == [(-7.2774982, -35.9635114), (-7.2802458, -35.9699874)]
    assert [z["name"] for z in s.zones] == ["hospital", "zone2"]
    assert len(s.zones[1]["polygon"]) == 3
    doc = (ROOT / "docs" / "paper_config_format.md").read_text()
    for block in (DOC_PROPS, DOC_TARGETS, DOC_ZONES):
        assert block in doc


def test_base_from_first_target_line(tmp_path):
    props = "uav.count=1\nstrategy: A\n"
    s = load_paper_config(make_cfg(tmp_path, props, DOC_TARGETS))
    assert s.base == (-7.275, -35.965, 0.0) and len(s.targets) == 2 and s.name == "cfg"


PAPER_BAD = [
    ("props", "uav.count=two\nstrategy=A\n", "init.properties: uav.count: expected an integer, got 'two'"),
    ("props", "uav.count=0\nstrategy=A\n", "init.properties: uav.count: must be >= 1, got 0"),
    ("props", "uav.count=1\nstrategy=Z\n", "init.properties: strategy: must be one of A, B, C, got 'Z'"),
    ("props", "uav.count=1\n", "init.properties: strategy: missing required field"),
    ("props", "uav.count=1\nstrategy=A\nwind.probability=2\n",
     "init.properties: wind.probability: must be <= 1, got 2"),
    ("props", "uav.count=1\nstrategy=A\nwind.gusts=maybe\n",
     "init.properties: wind.gusts: expected true or false, got 'maybe'"),
    ("props", "uav.count=1\nstrategy=A\nwind.weak=10\n",
     "init.properties: wind.weak/moderate/strong: speeds must satisfy weak <= moderate <= strong, got 10, 6, 9"),
    ("props", "uav.count=1\nstrategy=A\nbase.latitude=-7.2750\n",
     "init.properties: base.longitude: missing (both base.latitude and base.longitude, or neither)"),
    ("props", "uav.count=1\nstrategy=A\nfoo=1\n", "init.properties: foo: unknown key (line 3); known keys: name, "),
    ("props", "uav.count=1\nuav.count=2\nstrategy=A\n", "init.properties: uav.count: duplicate key (line 2)"),
    ("props", "uav.count 1\nstrategy=A\n", "init.properties: line 1: expected 'key=value', got 'uav.count 1'"),
    ("props", "uav.count=1\nstrategy=A\nbase.latitude=-7.2760\nbase.longitude=-35.9650\n",
     "targets.txt: line 1: landing point is 110.6 m from the base of init.properties (max 5 m; "
     "UAVs start and land at the base)"),
    ("targets", "-7.2750,-35.9650\n", "targets.txt: file: needs the landing point (first line) and at least one target"),
    ("targets", "-7.2750,-35.9650\n\n# c\n-7.27\n", "targets.txt: line 4: expected 'lat,lon', got '-7.27'"),
    ("targets", "-7.2750,-35.9650\n-7.27,abc\n", "targets.txt: line 2: expected a number, got 'abc'"),
    ("targets", "-7.2750,-35.9650\n-97.27,-35.9\n", "targets.txt: line 2: latitude must be in [-90, 90], got -97.27"),
    ("targets", "-7.2750,-35.9650\n-7.27,-35.96\n-8.27,-35.96\n",
     "targets.txt: line 3: 110.0 km from the base (max 50 km)"),
    ("zones", "a: -7.27,-35.96;-7.271,-35.96\n",
     "restrictedAreas.txt: line 1: polygon needs at least 3 'lat,lon' vertices, got 2"),
    ("zones", "# c\n: -7.27,-35.96;-7.271,-35.96;-7.271,-35.961\n", "restrictedAreas.txt: line 2: empty zone name before ':'"),
    ("zones", "-7.2774,-35.9636;-7.2776,-35.9636;-7.2776,-35.9634;-7.2774,-35.9634\n",
     "restrictedAreas.txt: line 1: covers target 0 (a target in a restricted zone cannot be visited)"),
    ("zones", "z: -7.271,-35.962;-7.2711,-35.962;-7.2711,-35.9621\n\nz: -7.272,-35.962;-7.2721,-35.962;-7.2721,-35.9621\n",
     "restrictedAreas.txt: line 3: duplicate zone name 'z'"),
]


@pytest.mark.parametrize("which,text,msg", PAPER_BAD, ids=[str(k) for k in range(len(PAPER_BAD))])
def test_paper_validation_messages(tmp_path, which, text, msg):
    props = "uav.count=1\nstrategy=A\n"
    targets = "-7.2750,-35.9650\n-7.2774982,-35.9635114\n"
    zones = None
    if which == "props":
        props = text
    elif which == "targets":
        targets = text
    else:
        zones = text
    d = make_cfg(tmp_path, props, targets, zones)
    with pytest.raises(ScenarioError) as ei:
        load_paper_config(d)
    assert str(ei.value).startswith(f"{d}/{msg}")
    assert "\n" not in str(ei.value)


def test_paper_missing_files(tmp_path):
    d = tmp_path / "empty"
    d.mkdir()
    with pytest.raises(ScenarioError) as ei:
        load_paper_config(d)
    assert str(ei.value).startswith(f"{d}/init.properties: file: cannot read")
