"""The two rule sets (``rules: paper | improved``) against hand-computed expectations.

Paper rules (docs/uav_models.md, "The paper's rules"): cruise V = 5 m/s and A = 1 m/s^2 (ArduCopter
WPNAV_SPEED 500 cm/s, WPNAV_ACCEL 100 cm/s/s of the paper's era), the paper's late 2 m zone detection, wind
that pushes the UAV (it is carried at the wind velocity; only its position loop, K = PSC_POSXY_P = 1/s,
corrects the displacement).
"""
import csv
import json
from pathlib import Path

import pytest
import yaml

from uavsim.dynamics import FLY, Dynamics, DynamicsParams
from uavsim.wind import Wind, WindParams
from uavstudy.build import build_ssp
from uavstudy.scenario import RULE_SETS, load_scenario_yaml, scenario_from_dict

import master
from uav_places import BASE
from uav_places import latlon as latlon8

ROOT = Path(__file__).resolve().parents[3]


def latlon(x, y):
    return latlon8(x, y, digits=9)


def one_leg_scenario(**kw):
    """One UAV at the base, one target 250 m east, a 60 m x 80 m zone across the leg from x = 100 m."""
    data = {"name": "one_leg", "base": list(BASE), "n_uavs": 1, "strategy": "A",
            "targets": [latlon(250.0, 0.0)],
            "zones": [{"name": "wall", "polygon": [latlon(100, -40), latlon(160, -40), latlon(160, 40),
                                                   latlon(100, 40)]}],
            "step": 0.05, "stop_time": 120.0}
    data.update(kw)
    return data


def run(data, tmp_path, name):
    scn = scenario_from_dict(data, f"{name}.yaml")
    ssp = build_ssp(scn, tmp_path / f"{name}.ssp")
    res = master.run(str(ssp), output=str(tmp_path / name), log_level="error")
    assert res.metadata["outcome"] == "completed"
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    with open(tmp_path / name / "events.csv", newline="") as fh:
        events = list(csv.DictReader(fh))
    return summary, events


def test_paper_rules_uav_enters_the_zone_at_the_hand_computed_time(tmp_path):
    summary, events = run(one_leg_scenario(rules="paper"), tmp_path, "paper")
    uav = summary["uavs"][0]
    assert uav["outcome"] == "zone_collision" and uav["removed_by"] == "wall"
    # The leg starts when the strategy enters TRANSIT (its goto reaches the vehicle over the next step).
    t_go = float(next(e["time"] for e in events if e["event"] == "transit"))
    # From rest the reference velocity ramps at A = 1 m/s^2 to V = 5 m/s (5 s, 12.5 m) and the vehicle
    # follows it exactly in still air (feed-forward); then 5 m/s.  The 2 m look-ahead sees the zone at
    # x = 98 m, after 5 + (98 - 12.5)/5 = 22.1 s.  The detour turns the reference by at most A t, so the last
    # 2 m take between 2/5 = 0.4 s and 5 - sqrt(25 - 4) = 0.417 s: entry 22.5-22.52 s after the start.
    # tolerance: the range above plus one master step (the command reaches the vehicle one step late)
    assert uav["removed_time"] - t_go == pytest.approx(22.51, abs=0.01 + 0.05)
    assert summary["total"]["settings"]["rules"] == "paper"


def test_improved_rules_plan_around_the_same_zone(tmp_path):
    summary, _ = run(one_leg_scenario(rules="improved", stop_time=300.0), tmp_path, "improved")
    uav = summary["uavs"][0]
    assert uav["outcome"] == "success" and uav["removed_time"] is None
    # the straight leg would be 2 x 250 m; the planned one goes round the 80 m wide zone with a 20 m margin
    assert uav["distance_xy_m"] > 2 * 250.0


def hover(push: bool, speed=5.0, accel=1.0):
    d = Dynamics(DynamicsParams(speed=speed, accel=accel, wind_push=push))
    while d.phase != FLY:
        d.step(0.1, 1)
    d.step(3.0, 1)
    return d


def wind_episode(level_speed: float, episode: float):
    """One episode with certainty: every level at ``level_speed``, from the east (pushes west)."""
    return Wind(WindParams(probability=1.0, seed=3, decision_interval=episode, duration=episode,
                           ramp=1.0, speed_weak=level_speed, speed_moderate=level_speed,
                           speed_strong=level_speed))


def fly_through_wind(d, wind, t_end, h=0.1):
    t, xs = 0.0, []
    while t < t_end - 1e-9:
        wx, wy, _, _ = wind.mean_over(t, t + h)
        d.step(h, 0, wind=(wx, wy, 0.0))
        t += h
        xs.append((round(t, 9), d.pos[0]))
    return xs


def test_paper_wind_pushes_a_hovering_uav_the_hand_computed_distance():
    # Carried at w = 3 m/s west, the position loop flies back at the speed sqrt_controller(d) asks for; the
    # drift stops where that speed equals the wind: sqrt(2 A (d - A/(2K^2))) = U, i.e.
    # d = U^2/(2A) + A/(2K^2) = 9/2 + 1/2 = 5.0 m (V = 5 > U, so the demand is not capped).
    d = hover(push=True)
    wind = wind_episode(3.0, 60.0)
    fly_through_wind(d, wind, 59.0)                 # the episode's last second is its decay ramp
    assert d.pos[0] == pytest.approx(-5.0, abs=0.01) and abs(d.pos[1]) < 1e-9
    assert d.airspeed == pytest.approx(3.0, abs=0.01)          # it flies at the wind's speed through the air
    assert d.groundspeed == pytest.approx(0.0, abs=0.01)
    # after the episode the position loop brings it back
    fly_through_wind(d, wind_episode(0.0, 60.0), 20.0)
    assert abs(d.pos[0]) < 0.01


def test_paper_wind_stronger_than_cruise_carries_the_uav_away():
    # U = 6 m/s > V = 5 m/s: the correction is capped at V, the UAV drifts downwind at U - V = 1 m/s
    d = hover(push=True)
    xs = dict(fly_through_wind(d, wind_episode(6.0, 60.0), 60.0))
    assert xs[50.0] - xs[40.0] == pytest.approx(-10.0, abs=0.01)


def test_drag_wind_is_rejected_by_the_autopilot():
    # the improved reading: air velocity in the drag law, the velocity loop's integrator removes the offset
    d = hover(push=False, speed=10.0, accel=2.5)
    xs = dict(fly_through_wind(d, wind_episode(3.0, 60.0), 60.0))
    assert abs(xs[59.0]) < 0.01 and min(xs.values()) > -0.2


def test_push_kernels_bit_identical_to_reference(any_kernels):
    import random
    rng = random.Random(11)
    p = DynamicsParams(speed=5.0, accel=1.0, wind_push=True)
    a, b = Dynamics(p, kernels=any_kernels), Dynamics(p)
    t = 0.0
    while t < 90.0:
        h = rng.choice([0.05, 0.1, 0.25, 1.0])
        cmd = 1 if t < 18 else (2 if t < 70 else 3)
        sp = (60.0 - (t // 9) * 23.0, (t // 13) * 31.0, 20.0)
        wind = (rng.uniform(-9, 0), rng.uniform(-3, 3), 0.0)
        a.step(h, cmd, sp, wind)
        b.step_reference(h, cmd, sp, wind)
        assert (a.pos, a.vel, a.vt, a.integ, a.phase, a.hold) == (b.pos, b.vel, b.vt, b.integ, b.phase, b.hold)
        t += h


def test_rule_set_defaults_and_explicit_fields_win():
    data = one_leg_scenario(rules="paper")
    s = scenario_from_dict(data, "x.yaml")
    assert (s.cruise_speed, s.max_accel, s.zone_planning) == (5.0, 1.0, False)
    assert (s.wind.shared, s.wind.effect, s.wind.decision_interval) == (False, "push", 10.0)
    s = scenario_from_dict({**data, "cruise_speed": 7.0, "wind": {"shared": True}}, "x.yaml")
    assert s.cruise_speed == 7.0 and s.wind.shared is True and s.wind.effect == "push"
    s = scenario_from_dict(one_leg_scenario(), "x.yaml")
    assert s.rules == "improved" and s.cruise_speed == 10.0 and s.zone_planning is True


def test_improved_rules_keep_the_fmus_own_defaults(tmp_path):
    # Bit-identity with the model before rule sets: every parameter the builder now sets for the improved
    # rules equals the FMU's own default (uavsim.params), so the shipped scenarios fly the same model.
    from uavsim import params as P
    scn = load_scenario_yaml(ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml")
    assert scn.rules == "improved"
    values = {(c, v): x for c, v, x in _ssd_parameters(build_ssp(scn, tmp_path / "z.ssp"))}
    assert values[("uav1_dyn", "speed")] == P.WP_SPEED and values[("uav1_dyn", "accel")] == P.WP_ACCEL
    assert values[("uav1_dyn", "wind_push")] is False
    assert values[("uav1_strat", "plan_margin")] == P.PLAN_MARGIN
    assert values[("uav1_strat", "brake_accel")] == P.WP_ACCEL
    assert values[("uav1_bat", "capacity_ah")] == P.CAPACITY_AH
    assert ("wind", "stream") not in values and ("wind", "decision_interval") in values
    assert values[("wind", "decision_interval")] == RULE_SETS["improved"]["wind.decision_interval"] == 1.0


def _ssd_parameters(ssp):
    import zipfile
    from lxml import etree
    with zipfile.ZipFile(ssp) as z:
        root = etree.fromstring(z.read("SystemStructure.ssd"))
    out = []
    for comp in root.iter("{*}Component"):
        for pv in comp.iter("{*}Parameter"):
            typ = pv[0]
            raw = typ.get("value")
            tag = etree.QName(typ).localname
            val = {"Real": float, "Integer": int, "Boolean": lambda s: s == "true"}.get(tag, str)(raw)
            out.append((comp.get("name"), pv.get("name"), val))
    return out


def test_per_uav_wind_and_staggered_takeoff_in_the_ssp(tmp_path):
    data = one_leg_scenario(rules="paper", n_uavs=3, takeoff="staggered", takeoff_interval=12.0,
                            targets=[latlon(250, 0), latlon(-250, 0), latlon(0, 250)])
    params = _ssd_parameters(build_ssp(scenario_from_dict(data, "x.yaml"), tmp_path / "s.ssp"))
    values = {(c, v): x for c, v, x in params}
    assert [values[(f"uav{i}_wind", "stream")] for i in (1, 2, 3)] == [0, 1, 2]
    assert [values[(f"uav{i}_dyn", "preflight_time")] for i in (1, 2, 3)] == [5.0, 17.0, 29.0]
    assert all(values[(f"uav{i}_dyn", k)] == 0.0 for i in (1, 2, 3) for k in ("home_x", "home_y"))
    # per-UAV streams of one seed are independent draws
    a, b = (Wind(WindParams(probability=0.5, seed=7, stream=k)) for k in (0, 1))
    assert [a.level_at(t)[0] for t in range(0, 200, 10)] != [b.level_at(t)[0] for t in range(0, 200, 10)]


# ----------------------------------------------------------------------------- campaigns
def _campaign(tmp_path, scenario_text, rules="paper", name="c"):
    (tmp_path / "scn.yaml").write_text(scenario_text)
    spec = {"name": name, "seed": 5, "repetitions": 2, "scenario": "scn.yaml",
            "grid": {"strategy": ["A", "B"], "layout": "random", **({"rules": rules} if rules else {})},
            "run": {"step": 0.5, "stop_time": 40, "csv": False}, "keep": "summary", "paired": ["strategy"]}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def _scenario_text(rules_line=""):
    data = one_leg_scenario(targets=[latlon(x, y) for x, y in ((250, 0), (-200, 100), (0, -300), (150, 220))])
    data.pop("step"), data.pop("stop_time")
    return rules_line + yaml.safe_dump(data)


def _records(out):
    return {r["run_id"]: r for r in (json.loads(p.read_text()) for p in (out / "runs").glob("*.json"))}


def test_repetitions_fly_their_own_layouts_and_reruns_are_identical(tmp_path):
    from master.campaign.runner import run_campaign
    from uavstudy.campaign_kind import layout_seed
    from uavstudy.layout import realize
    camp = _campaign(tmp_path, _scenario_text())
    s1 = run_campaign(camp, output=tmp_path / "out1", workers=1, progress=False)
    s2 = run_campaign(camp, output=tmp_path / "out2", workers=1, progress=False)
    assert s1.ok and s2.ok
    r1, r2 = _records(tmp_path / "out1"), _records(tmp_path / "out2")
    assert len(r1) == 4
    seeds = {(r["params"]["strategy"], r["rep"]): r["summary"]["total"]["settings"]["layout_seed"]
             for r in r1.values()}
    # the layout seed is the campaign seed's and the repetition's only: A and B share it, the reps differ
    assert seeds[("A", 0)] == seeds[("B", 0)] == layout_seed(5, 0)
    assert seeds[("A", 1)] == seeds[("B", 1)] == layout_seed(5, 1) != layout_seed(5, 0)
    layouts = {}
    for rid, r in r1.items():
        scn = load_scenario_yaml(tmp_path / "out1" / "runs" / rid / "scenario.yaml")
        layouts[r["rep"]] = realize(scn).targets.round(3).tolist()
        assert r["summary"]["total"]["settings"]["rules"] == "paper"
    assert layouts[0] != layouts[1]
    for rid in r1:
        assert r1[rid]["summary"] == r2[rid]["summary"]


def test_changing_the_rule_set_makes_records_stale(tmp_path):
    from master.campaign.runner import run_campaign
    camp = _campaign(tmp_path, _scenario_text("rules: improved\n"), rules=None)   # from the scenario file
    spec = yaml.safe_load(camp.read_text())
    spec["repetitions"] = 1
    camp.write_text(yaml.safe_dump(spec))
    s1 = run_campaign(camp, output=tmp_path / "out", workers=1, progress=False)
    assert s1.ok and s1.completed == 2
    rec = next(iter(_records(tmp_path / "out").values()))
    assert rec["summary"]["total"]["settings"]["rules"] == "improved"
    run_json = json.loads((tmp_path / "out" / "runs" / rec["run_id"] / "run.json").read_text())
    assert run_json["monitors"]["org.cosim-master.uav-monitor"]["total"]["settings"]["rules"] == "improved"
    (tmp_path / "scn.yaml").write_text(_scenario_text("rules: paper\n"))
    s2 = run_campaign(camp, output=tmp_path / "out", workers=1, progress=False)
    assert s2.stale == 2 and s2.ok
    assert {r["summary"]["total"]["settings"]["rules"] for r in _records(tmp_path / "out").values()} == {"paper"}


def test_paper_properties_file_selects_the_rule_set(tmp_path):
    from uavstudy.scenario import PAPER_KEYS, load_paper_config
    (tmp_path / "init.properties").write_text("uav.count=2\nstrategy=B\nrules=paper\ntakeoff=staggered\n"
                                              "takeoff.interval=20\nuav.cruise_speed=6\n")
    (tmp_path / "targets.txt").write_text("-7.275,-35.965\n-7.2774982,-35.9635114\n")
    s = load_paper_config(tmp_path)
    assert (s.rules, s.takeoff, s.takeoff_interval, s.cruise_speed, s.max_accel) == ("paper", "staggered", 20.0,
                                                                                      6.0, 1.0)
    doc = (ROOT / "docs" / "paper_config_format.md").read_text(encoding="utf-8")
    assert all(f"`{key}`" in doc for key in PAPER_KEYS)        # every properties key is documented
