"""Unit tests of the UAV monitor plugin (uavstudy.monitor) with a fake master context."""
import json
import math

import numpy as np
import pytest
from lxml import etree

from master.errors import ScenarioError
from master.monitors import MONITORS
from uavstudy.monitor import MONITOR_TYPE, UavMonitor, parse_config
from uavstudy.monitor_accel import ScriptedContext

SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
UAV = "https://cosim-master.org/ssp/uav"
ROLES = {"x": "x", "y": "y", "z": "z", "phase": "phase", "missionState": "mission_state", "consumed": "consumed",
         "soc": "soc", "photoCount": "photo_count", "lastPhotoTarget": "last_photo_target",
         "lastPhotoTime": "last_photo_time", "lastPhotoX": "last_photo_x", "lastPhotoY": "last_photo_y",
         "targetsAssigned": "targets_assigned", "targetsVisited": "targets_visited"}
INTEGER = {"phase", "mission_state", "photo_count", "last_photo_target", "targets_assigned", "targets_visited"}


def annotation(names, zones=(), targets=(), impact=2.6, homes=None, extra=""):
    uavs = []
    for k, n in enumerate(names):
        hx, hy = homes[k] if homes else (0.0, 0.0)
        attrs = " ".join(f'{role}="{n}.{var}"' for role, var in ROLES.items())
        uavs.append(f'<uav:Uav name="{n}" index="{k}" components="{n}_dyn {n}_strat" homeX="{hx}" homeY="{hy}" '
                    f'{attrs}/>')
    zs = "".join(f'<uav:Zone name="{name}">{" ".join(f"{x},{y}" for x, y in poly)}</uav:Zone>'
                 for name, poly in zones)
    ts = f'<uav:Targets>{" ".join(f"{x},{y}" for x, y in targets)}</uav:Targets>' if targets else ""
    xml = (f'<ssc:Annotation xmlns:ssc="{SSC}" type="{MONITOR_TYPE}"><uav:UavMonitor xmlns:uav="{UAV}" '
           f'impactDiameter="{impact}" originLatitude="45.0" originLongitude="7.0" originAltitude="250.0" '
           f'scenario="unit" strategy="B" {extra}>{"".join(uavs)}{ts}{zs}</uav:UavMonitor></ssc:Annotation>')
    return etree.fromstring(xml)


def make(names, **kw):
    mon = UavMonitor(annotation(names, **kw), None, "unit.ssp")
    ctx = ScriptedContext(names, ROLES.values(), INTEGER)
    return mon, ctx


def fly(mon, ctx, positions, phases=None, t_start=0.0, h=1.0, steps=10):
    """positions(name, t) -> (x, y, z); every UAV in phase 2 (fly) unless phases(name, t) says otherwise."""
    names = [u.name for u in mon.cfg.uavs]

    def load(t):
        for n in names:
            x, y, z = positions(n, t)
            ctx.set(n, x=x, y=y, z=z, phase=phases(n, t) if phases else 2)
    load(t_start)
    mon.attach(ctx, t_start)
    for n in range(steps):
        t0, t1 = t_start + n * h, t_start + (n + 1) * h
        load(t1)
        mon.after_step(n, t0, t1)


def test_registered():
    assert MONITORS.find(MONITOR_TYPE) is UavMonitor


def test_crossing_uavs_removed_at_hand_computed_contact_time():
    # a flies east along y=0, b north along x=0, both 10 m/s at 20 m; both reach the origin at t=5.
    # distance sqrt(2)*|50 - 10 t| = 2.6  ->  t = 5 - 2.6 / (10 sqrt 2) = 4.81615... (inside the step [4, 5])
    mon, ctx = make(["a", "b"])
    pos = {"a": lambda t: (-50 + 10 * t, 0.0, 20.0), "b": lambda t: (0.0, -50 + 10 * t, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t))
    hits = [e for e in ctx.events if e["type"] == "uav"]
    assert len(hits) == 1
    e = hits[0]
    assert e["time"] == pytest.approx(5 - 2.6 / (10 * math.sqrt(2)), abs=1e-9)
    assert {e["uav"], e["other"]} == {"a", "b"}
    assert e["event"] == "collision" and e["distance"] == pytest.approx(2.6)
    assert e["z"] == pytest.approx(20.0)
    assert math.isfinite(e["lat"]) and math.isfinite(e["lon"])
    assert ctx.deactivated == ["a_dyn", "a_strat", "b_dyn", "b_strat"]
    assert all(r.removed and r.removed_reason == "uav_collision" for r in mon.records)
    assert mon.records[0].removed_by == "b" and mon.records[1].removed_by == "a"
    # a removed UAV is not checked again, and its distance stops at the contact
    assert mon.records[0].removed_time == pytest.approx(e["time"])
    mon.sync()
    assert mon.records[0].distance == pytest.approx(10 * e["time"], rel=1e-9)
    summary = mon.finish(None, "completed")
    assert summary["uavs"] == {"a": "uav_collision", "b": "uav_collision"}
    assert summary["total"]["uav_collisions"] == 1


def test_contact_point_position():
    mon, ctx = make(["a", "b"])
    pos = {"a": lambda t: (-50 + 10 * t, 0.0, 20.0), "b": lambda t: (0.0, -50 + 10 * t, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t))
    e = next(e for e in ctx.events if e["type"] == "uav")
    c = 2.6 / math.sqrt(2)      # each centre is 1.84 m before the origin along its axis
    assert mon.records[0].removed_pos == (pytest.approx(-c), pytest.approx(0.0), pytest.approx(20.0))
    assert mon.records[1].removed_pos == (pytest.approx(0.0), pytest.approx(-c), pytest.approx(20.0))
    # the event's position is the midpoint of the two centres
    assert (e["x"], e["y"]) == (pytest.approx(-c / 2), pytest.approx(-c / 2))


def test_parallel_uavs_3m_apart_not_flagged():
    mon, ctx = make(["a", "b"])
    pos = {"a": lambda t: (10 * t, 0.0, 20.0), "b": lambda t: (10 * t, 3.0, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t))
    assert not [e for e in ctx.events if e["type"] in ("uav", "zone")]
    assert ctx.deactivated == []


def test_exactly_impact_diameter_apart_is_a_contact():
    mon, ctx = make(["a", "b"])
    pos = {"a": lambda t: (10 * t, 0.0, 20.0), "b": lambda t: (10 * t, 2.6, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t), steps=2)
    hits = [e for e in ctx.events if e["type"] == "uav"]
    assert len(hits) == 1 and hits[0]["time"] == 0.0


def test_zone_corner_cut_detected():
    # zone [10, 20] x [10, 20]; the step from (7, 16) to (13, 22) cuts its north-west corner, both ends outside
    zone = ("box", [(10, 10), (20, 10), (20, 20), (10, 20)])
    mon, ctx = make(["a"], zones=[zone])
    track = {0.0: (1.0, 10.0, 20.0), 1.0: (7.0, 16.0, 20.0), 2.0: (13.0, 22.0, 20.0), 3.0: (19.0, 28.0, 20.0)}
    fly(mon, ctx, lambda n, t: track[t], steps=3)
    zs = [e for e in ctx.events if e["type"] == "zone"]
    assert len(zs) == 1
    e = zs[0]
    assert e["uav"] == "a" and e["other"] == "box" and e["event"] == "zone_incursion"
    assert e["time"] == pytest.approx(1.5)            # enters at x = 10, half-way along the step
    assert (e["x"], e["y"]) == (pytest.approx(10.0), pytest.approx(19.0))
    assert "corner" in e["detail"]
    assert ctx.deactivated == ["a_dyn", "a_strat"]
    assert mon.records[0].removed_reason == "zone_collision"
    assert mon.finish(None, "completed")["uavs"]["a"] == "zone_collision"


def test_grounded_and_low_uavs_not_checked():
    # a and b stand at the same place (preflight, then landed), c and d lift off 1 m apart but stay below
    # 0.5 m, e flies over a at 20 m; f is landed inside a zone
    zone = ("z", [(100, 100), (110, 100), (110, 110), (100, 110)])
    names = ["a", "b", "c", "d", "e", "f"]
    mon, ctx = make(names, zones=[zone])
    pos = {"a": (0, 0, 0), "b": (0, 0, 0), "c": (50, 0, 0.3), "d": (51, 0, 0.3), "f": (105, 105, 0)}
    phase = {"a": lambda t: 0 if t < 3 else 4, "b": lambda t: 0 if t < 3 else 4, "c": lambda t: 1,
             "d": lambda t: 1, "e": lambda t: 2, "f": lambda t: 4}

    def where(n, t):
        return (-20 + 10 * t, 0.0, 20.0) if n == "e" else pos[n]
    fly(mon, ctx, where, phases=lambda n, t: phase[n](t), steps=6)
    assert [e for e in ctx.events if e["type"] in ("uav", "zone")] == []
    assert ctx.deactivated == []


def test_airborne_uav_in_takeoff_phase_is_checked():
    mon, ctx = make(["a", "b"])
    fly(mon, ctx, lambda n, t: (0.0, 0.0 if n == "a" else 2.0, 5.0), phases=lambda n, t: 1, steps=1)
    assert len([e for e in ctx.events if e["type"] == "uav"]) == 1


def test_first_contact_wins_within_a_step():
    # a meets b at t ~ 0.4 and would meet c later in the same step: only a-b counts, c stays
    mon, ctx = make(["a", "b", "c"])
    track = {"a": lambda t: (10 * t, 0.0, 20.0), "b": lambda t: (6.6, 0.0, 20.0), "c": lambda t: (12.0, 0.0, 20.0)}
    fly(mon, ctx, lambda n, t: track[n](t), steps=1)
    hits = [e for e in ctx.events if e["type"] == "uav"]
    assert len(hits) == 1 and {hits[0]["uav"], hits[0]["other"]} == {"a", "b"}
    assert hits[0]["time"] == pytest.approx(0.4)
    assert not mon.records[2].removed


def test_mission_events_and_photos():
    mon, ctx = make(["a"], targets=[(50, 0), (50, 50)])
    ctx.set("a", mission_state=0, phase=0)
    mon.attach(ctx, 0.0)
    script = [  # t1, mission_state, consumed, photo_count, last photo (target, time, x, y)
        (1.0, 1, 0.01, 0, None), (2.0, 2, 0.02, 0, None), (3.0, 2, 0.3, 1, (0, 2.0, 49.5, 0.2)),
        (4.0, 4, 0.8, 1, None), (5.0, 6, 0.95, 1, None), (6.0, 8, 0.96, 1, None)]
    for n, (t1, ms, cons, pc, photo) in enumerate(script):
        ctx.set("a", mission_state=ms, consumed=cons, soc=1 - cons, photo_count=pc, phase=2 if ms < 8 else 4,
                x=40.0, z=20.0 if ms < 8 else 0.0)
        if photo:
            ctx.set("a", last_photo_target=photo[0], last_photo_time=photo[1], last_photo_x=photo[2],
                    last_photo_y=photo[3])
        mon.after_step(n, t1 - 1.0, t1)
    names = [e["event"] for e in ctx.events if e["type"] == "mission"]
    assert names == ["takeoff", "transit", "return_low", "forced_landing", "landed_away"]
    rl = next(e for e in ctx.events if e["event"] == "return_low")
    assert rl["time"] == 3.0 and rl["consumed"] == pytest.approx(0.8)
    assert mon.records[0].photos == [{"target": 0, "time": 2.0, "x": 49.5, "y": 0.2, "z": 20.0}]
    ctx.set("a", targets_assigned=2, targets_visited=1)
    s = mon.finish(None, "completed")
    assert s["uavs"]["a"] == "forced_landing"
    assert s["total"]["photos_sum"] == 1 and s["total"]["targets_visited"] == 1


def test_finish_writes_outputs_without_results(tmp_path):
    # no results.parquet (e.g. the run failed early): trajectory from the monitor's own track
    mon, ctx = make(["a", "b"], targets=[(5, 5)], zones=[("z", [(30, -5), (40, -5), (40, 5), (30, 5)])])
    pos = {"a": lambda t: (10 * t, 0.0, 20.0), "b": lambda t: (0.0, 50.0, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t), steps=6)
    s = mon.finish(tmp_path, "error")
    assert s["uavs"] == {"a": "zone_collision", "b": "run_error"}
    for f in ("trajectory.csv", "photos.csv", "summary.csv", "summary.json", "map.png"):
        assert (tmp_path / f).is_file(), f
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["total"]["run_outcome"] == "error" and doc["total"]["zone_collisions"] == 1
    import pandas as pd
    tr = pd.read_csv(tmp_path / "trajectory.csv")
    a = tr[tr.uav == "a"]
    assert a.iloc[-1]["status"] == "removed" and a.iloc[-1]["x"] == pytest.approx(30.0)
    assert a.iloc[-1]["time"] == pytest.approx(3.0)


def test_monitor_never_attached(tmp_path):
    mon, _ = make(["a"])
    s = mon.finish(tmp_path, "error")
    assert s["uavs"] == {"a": "run_error"}
    assert (tmp_path / "summary.json").is_file()


def test_bad_annotations():
    with pytest.raises(ScenarioError, match="missing attribute"):
        parse_config(etree.fromstring(f'<a xmlns:uav="{UAV}"><uav:UavMonitor><uav:Uav name="a" components="c" '
                                      f'x="c.x"/></uav:UavMonitor></a>'), "s.ssp")
    with pytest.raises(ScenarioError, match="no uav:UavMonitor"):
        parse_config(etree.fromstring("<a/>"), "s.ssp")
    with pytest.raises(ScenarioError, match="not a number"):
        parse_config(annotation(["a"], impact="big"), "s.ssp")


# ------------------------------------------------------------------ a scripted fleet, step by step
def _scripted_fleet(zones):
    """Ten UAVs over 40 s in 0.5 s steps: a long all-on-the-ground start, a UAV with a NaN altitude on its
    pad, a UAV-UAV crossing, a zone incursion, a hovering UAV (identical positions while airborne), a UAV in
    take-off phase below the altitude threshold (airborne time without checks), a landing, mission states and
    photos."""
    names = [f"u{k}" for k in range(10)]
    mon, ctx = make(names, zones=zones, homes=[(8.0 * k, -30.0) for k in range(10)])

    def state(n, t):
        k = int(n[1:])
        home = (8.0 * k, -30.0, 0.0)
        if k == 6 and 2.0 <= t < 4.0:
            return (home[0], home[1], math.nan), 0
        if t < 5.0 or k >= 6:
            return home, 0
        f = t - 5.0
        if k == 0:
            return (-60.0 + 6.0 * f, 0.0, 20.0), 2                      # east along y = 0
        if k == 1:
            return (0.0, -60.0 + 6.0 * f, 20.0), 2                      # north along x = 0: meets u0
        if k == 2:
            return (100.0 + 5.0 * f, 40.0 + 0.3 * f, 20.0), 2           # into the zone at x >= 150
        if k == 3:
            return ((300.0, 0.0, 20.0), 2) if t < 30.0 else ((300.0, 0.0, 0.0), 4)   # hovers, then lands
        if k == 4:
            return ((32.0, -30.0, 0.3), 1) if t >= 10.0 else (home, 0)  # lifting, below 0.5 m
        if k == 5:
            return ((-100.0 + 4.0 * f, 80.0, 20.0), 2) if t < 25.0 else ((-20.0, 80.0, 0.0), 4)
        return home, 0

    def load(t, step):
        for n in names:
            if f"{n}_dyn" in ctx.deactivated:     # the master: a removed UAV's outputs keep their values
                continue
            (x, y, z), ph = state(n, t)
            ctx.set(n, x=x, y=y, z=z, phase=ph)
        ms = 0 if t < 5.0 else 1 if t < 6.0 else 2 if t < 25.0 else 7
        ctx.set("u5", mission_state=ms, consumed=0.001 * step)
        if step in (20, 21, 40):    # photos in consecutive steps, then two within one step
            ctx.set("u5", photo_count={20: 1, 21: 2, 40: 4}[step], last_photo_target=step % 3,
                    last_photo_time=0.5 * step - 0.25, last_photo_x=1.0 * step, last_photo_y=-1.0)
    return mon, ctx, load



@pytest.mark.parametrize("zones", [True, False])
@pytest.mark.parametrize("step", ["reference", "accelerated"])
def test_scripted_fleet(zones, step):
    """What the monitor makes of the scripted fleet, by hand: the crossing, the incursion (with a zone), the
    NaN altitude's NaN distance, 30.5 s airborne below the threshold (phase 1 from t = 10 s), the photos
    (two within one step: one missed).  The reference step and the accelerated one (the default) alike."""
    from uavstudy.monitor_step import ReferenceStep
    zone = [("z", [(150, 20), (200, 20), (200, 80), (150, 80)])] if zones else ()
    mon, ctx, load = _scripted_fleet(zone)
    if step == "reference":
        mon.step_factory = ReferenceStep
    load(0.0, 0)
    mon.attach(ctx, 0.0)
    for k in range(80):
        load(0.5 * (k + 1), k + 1)
        mon.after_step(k, 0.5 * k, 0.5 * (k + 1))
    assert isinstance(mon.step, ReferenceStep) is (step == "reference")
    mon.sync()
    ev = [(e["type"], e["event"], e["uav"]) for e in ctx.events]
    assert ("uav", "collision", "u0") in ev and ("mission", "landed_base", "u5") in ev
    assert (("zone", "zone_incursion", "u2") in ev) is zones
    recs = mon.records
    assert math.isnan(recs[6].distance)                     # NaN altitude once: NaN distance
    assert recs[4].flight_time == 30.5 and recs[4].distance == pytest.approx(0.3)
    assert len(recs[5].photos) == 3 and recs[5].photos[2]["missed_before"] == 1
    # u3: from its pad (24, -30, 0) to (300, 0, 20) in one step, hovers, then straight down
    assert recs[3].distance == pytest.approx(math.sqrt(276 ** 2 + 30 ** 2 + 20 ** 2) + 20.0)
    # u0: from its pad to (-60, 0, 20) (70 m), then east until it is 2.6 m from u1, within a step (it flies its
    # share of that step): 60 - 2.6 / sqrt(2) m
    assert recs[0].removed and recs[0].distance == pytest.approx(70.0 + 60.0 - 2.6 / math.sqrt(2))


def test_pure_python_variable_runs_the_reference(monkeypatch):
    from uavstudy.monitor_step import ReferenceStep
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    mon, ctx = make(["a", "b"])
    fly(mon, ctx, lambda n, t: (10.0 * t, 0.0 if n == "a" else 50.0, 20.0), steps=2)
    assert type(mon.step) is ReferenceStep
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "0")
    mon, ctx = make(["a", "b"])
    fly(mon, ctx, lambda n, t: (10.0 * t, 0.0 if n == "a" else 50.0, 20.0), steps=2)
    assert type(mon.step) is not ReferenceStep


def test_accelerator_cases_hold_every_kind_of_event():
    """The fleets the accelerator harness flies (uavstudy.monitor_accel) are not vacuous: on the reference they
    hold contacts (also at exactly the impact diameter), near misses, zone incursions, mission events, photos
    and stop requests, in fleets small and large."""
    import random

    from uavstudy import monitor_accel
    from uavstudy.monitor_step import ReferenceStep
    kinds, sizes, stops, photos, at_d = set(), set(), 0, 0, 0
    for seed in range(3):
        for case in monitor_accel.fleet_cases(random.Random(seed), 12, monitor_accel.ALL_SIZES):
            out = monitor_accel.fly(case, ReferenceStep)
            kinds |= {e["type"] for e in out["events"]}
            at_d += sum(e["type"] == "uav" and abs(e["distance"] - 2.6) < 1e-9 for e in out["events"])
            sizes.add(case.position.shape[1] > 16)
            stops += bool(out["stops"])
            photos += sum(len(r["photos"]) for r in out["records"])
    assert kinds == {"uav", "zone", "mission"} and sizes == {True, False}
    assert stops >= 3 and photos >= 10 and at_d >= 10


def test_idle_steps_share_track_arrays_and_memory_stays_flat():
    # a long wait on the ground: the thinned track holds references to one position array, nothing per step
    mon, ctx = make(["a", "b"])
    fly(mon, ctx, lambda n, t: (0.0, 5.0 if n == "a" else -5.0, 0.0), phases=lambda n, t: 0, h=0.1, steps=1000)
    assert len(mon.track_t) == 201                              # every 0.5 s of 100 s, plus the start
    assert len({id(p) for p in mon.track_p}) <= 2
    assert mon.records[0].mission_states == [] and ctx.events == []


# ------------------------------------------------------------------------------ the end of a mission
def test_fleet_removed_by_a_collision_stops_the_run():
    """endWhenAllLanded: a fleet all removed has nothing left to do, like one that has landed."""
    mon, ctx = make(["a", "b"], extra='endWhenAllLanded="true"')
    pos = {"a": lambda t: (-50 + 10 * t, 0.0, 20.0), "b": lambda t: (0.0, -50 + 10 * t, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t), steps=5)          # the contact is in the step [4, 5]
    assert all(r.removed for r in mon.records)
    assert [reason for _, reason in ctx.stops] == ["every UAV has landed or been removed"]


def test_one_uav_left_keeps_the_run_going():
    mon, ctx = make(["a", "b", "c"], extra='endWhenAllLanded="true"')
    pos = {"a": lambda t: (-50 + 10 * t, 0.0, 20.0), "b": lambda t: (0.0, -50 + 10 * t, 20.0),
           "c": lambda t: (300.0, 300.0, 20.0)}
    fly(mon, ctx, lambda n, t: pos[n](t), steps=5)
    assert [r.removed for r in mon.records] == [True, True, False] and [reason for _, reason in ctx.stops] == []


def test_mission_end_time_is_the_last_landing_or_removal():
    from uavstudy.outputs import map_title
    mon, ctx = make(["a", "b"])
    ctx.set("a", mission_state=0, phase=0)
    ctx.set("b", mission_state=0, phase=0)
    mon.attach(ctx, 0.0)
    # a lands at base (state 7) seen in the step [300, 301]; b is removed by a zone at t = 120 (hand-set)
    mon.records[1].removed_time = 120.0
    mon.records[1].removed = True
    mon.records[1].removed_reason = "zone_collision"
    mon.fleet.removed[1] = True
    for n, (t0, t1, ms) in enumerate([(0.0, 1.0, 1), (1.0, 2.0, 2), (299.0, 300.0, 5), (300.0, 301.0, 7)]):
        ctx.set("a", mission_state=ms, phase=4 if ms == 7 else 2, z=0.0 if ms == 7 else 20.0)
        mon.after_step(n, t0, t1)
    s = mon.finish(None, "completed")
    assert s["total"]["mission_end_time"] == 300.0     # the landing was registered at t0 of its step
    mon.last_time = 1500.0
    total = dict(s["total"], end_time=1500.0)
    title = map_title(mon.cfg, total)
    assert "mission ended at t=300.0 s" in title and "1500" not in title
    total["mission_end_time"] = None
    assert "mission unfinished when the run stopped at t=1500.0 s" in map_title(mon.cfg, total)


def test_seed_is_the_one_the_run_gave_the_wind():
    """plan.params lists the SSD's values, then the overrides (run --seed): the last one is the FMU's."""
    from types import SimpleNamespace

    from uavstudy.monitor import run_seed

    def var(comp, name):
        return SimpleNamespace(component=comp, name=name)
    plan = SimpleNamespace(params=[(var("wind", "seed"), 1, "SystemStructure.ssd:12"),
                                   (var("uav1_dyn", "seed"), 5, "command line"),
                                   (var("wind", "probability"), 0.2, "SystemStructure.ssd:13"),
                                   (var("wind", "seed"), 42, "command line")])
    assert run_seed(plan, "1") == "42"
    assert run_seed(SimpleNamespace(params=[]), "1") == "1"


# ------------------------------------------------------------------------------ map
def test_uav_styles_are_distinct_beyond_ten_uavs():
    from uavstudy.outputs import uav_styles
    for n in (4, 10, 12, 20, 45):
        styles = uav_styles(n)
        assert len(set(styles)) == n, n
    assert len({c for c, _ in uav_styles(12)}) == 12       # 12 UAVs: 12 colours, no repeat


def test_time_marks_and_arrows_on_a_track():
    """A UAV parked until t = 10 s, then east at 10 m/s until t = 150 s: marks at t = 60 and 120 s, i.e.
    x = 500 and 1100 m; arrows at t = 30, 90 s (x = 200, 800 m) pointing east; none while parked."""
    from matplotlib.figure import Figure

    from uavstudy.outputs import _flight_marks
    t = np.arange(0.0, 150.5, 0.5)
    x = np.where(t < 10.0, 0.0, 10.0 * (t - 10.0))
    xy = np.column_stack((x, np.zeros_like(x)))
    ax = Figure().add_subplot(1, 1, 1)
    _flight_marks(ax, t, xy, "C0")
    dots = ax.collections[0].get_offsets()
    np.testing.assert_allclose(dots, [[500.0, 0.0], [1100.0, 0.0]])
    arrows = [(a.xyann, a.xy) for a in ax.texts]
    np.testing.assert_allclose([tail for tail, _ in arrows], [(190.0, 0.0), (790.0, 0.0)])
    np.testing.assert_allclose([head for _, head in arrows], [(210.0, 0.0), (810.0, 0.0)])


def test_landing_markers_are_hollow_and_the_base_on_top(tmp_path):
    from uavstudy.outputs import END_MARKERS
    assert END_MARKERS["landed"][0]["facecolors"] == "none" and END_MARKERS["forced"][0]["facecolors"] == "none"
    mon, ctx = make(["a", "b"], targets=[(50, 0)])
    # a flies (phase 2, on the ground) in the first step and lands on its pad, at the base; b never flies
    fly(mon, ctx, lambda n, t: (0.0, 0.0, 0.0), phases=lambda n, t: 2 if (n, t) == ("a", 1.0) else 4, steps=2)
    import matplotlib.figure
    seen = {}
    orig = matplotlib.figure.Figure.savefig

    def keep(fig, path, *a, **k):
        seen["ax"] = fig.axes[0]
        return orig(fig, path, *a, **k)
    matplotlib.figure.Figure.savefig = keep
    try:
        mon.finish(tmp_path, "completed")
    finally:
        matplotlib.figure.Figure.savefig = orig
    base = [c for c in seen["ax"].collections if c.get_zorder() == 8]
    assert len(base) == 1 and base[0].get_offsets().tolist() == [[0.0, 0.0]]
    assert max(c.get_zorder() for c in seen["ax"].collections) == 8
    landed = [c for c in seen["ax"].collections if c.get_zorder() == 6]
    assert len(landed) == 1 and landed[0].get_facecolor().size == 0       # hollow: the base shows through
