"""The monitor's common step in C (uavstudy/monitor_step.c) against its Python twin (UavMonitor._step_small)
and against the exact reference (every check run, ``precheck=False``): state compared bit for bit after every
step, and events, removals, records and the map track after whole runs, on seeded fleets built around the
cases where the skip bound is tight: pairs passing within +-1 cm of the impact diameter, a UAV stopping or
sliding within +-1 cm of a zone's edge, a NaN position, landings, mission-state changes (Python steps in
between the C ones)."""
import dataclasses
import math

import numpy as np
import pytest

from test_uav_monitor import FakeCtx, annotation
from uavstudy import monitor_native
from uavstudy.monitor import UavMonitor

D = 2.6
ZONE = [(300.0, -20.0), (340.0, -20.0), (340.0, 10.0), (300.0, 10.0)]
NAMES = [f"u{k}" for k in range(6)]

if monitor_native.step_function()[0] is None:
    pytest.skip(f"no C step: {monitor_native.step_function()[1]}", allow_module_level=True)


def _unit(v):
    return v / np.linalg.norm(v)


def _near_miss(rng, duration):
    """Two straight constant-speed tracks whose closest approach, at a time between two samples, is D + gap
    with gap in +-1 cm (hand construction: the offset at that time is perpendicular to the relative velocity,
    so it is the minimum of the relative distance)."""
    va = rng.uniform(1.0, 12.0) * _unit(rng.normal(size=3) * (1, 1, 0.1))
    vb = rng.uniform(1.0, 12.0) * _unit(rng.normal(size=3) * (1, 1, 0.1))
    if rng.random() < 0.3:
        vb = -va * rng.uniform(0.5, 1.5)                   # head-on: the bound is exact there
    rel = va - vb
    w = _unit(np.cross(rel, rng.normal(size=3)))
    gap = rng.uniform(-0.01, 0.01)
    tc = rng.uniform(0.35, 0.65) * duration
    c = np.array([rng.uniform(-60, 60), rng.uniform(-60, 60), 20.0 + rng.uniform(-1, 1)])
    a, b = c + 0.5 * (D + gap) * w, c - 0.5 * (D + gap) * w
    return (lambda t: a + va * (t - tc)), (lambda t: b + vb * (t - tc)), gap


def _zone_skimmer(rng, duration):
    """Flies at the zone's west edge (x = 300), stops with its xy within +-1 cm of it for a while, then slides
    north along it at +-1 cm and turns away: an incursion or not, decided at the centimetre."""
    gap = rng.uniform(-0.01, 0.01)
    y0 = rng.uniform(-15.0, 5.0)
    speed = rng.uniform(2.0, 10.0)
    t_arrive = rng.uniform(0.2, 0.4) * duration
    t_slide = t_arrive + rng.uniform(1.0, 5.0)
    edge = 300.0 - gap

    def pos(t):
        if t <= t_arrive:
            return np.array([edge - speed * (t_arrive - t), y0, 20.0])
        if t <= t_slide:
            return np.array([edge, y0, 20.0])
        return np.array([edge - 0.02 * (t - t_slide) ** 2, y0 + speed * (t - t_slide), 20.0])
    return pos, gap


def fleet(seed):
    """(h, steps, load(ctx, s)) of a seeded 6-UAV run: two near-miss pairs, a zone skimmer, a random walker
    that reads NaN once, changes its mission state and lands."""
    rng = np.random.default_rng(seed)
    h = float(rng.choice([0.1, 0.25, 0.5, 1.0]))
    steps = 160
    duration = h * steps
    (a0, b0, _), (a1, b1, _) = _near_miss(rng, duration), _near_miss(rng, duration)
    skim, _ = _zone_skimmer(rng, duration)
    walk = [np.array([rng.uniform(-80, 80), rng.uniform(-80, 80), 20.0])]
    for _ in range(steps):
        walk.append(walk[-1] + h * rng.normal(0.0, 3.0, 3) * (1, 1, 0.1))
    nan_at, ms_at, land_at = rng.integers(5, steps, 3)

    def load(ctx, s):
        t = h * s
        p = [a0(t), b0(t), a1(t), b1(t), skim(t), walk[s].copy()]
        phase = [2] * 6
        if s >= land_at:
            phase[5], p[5][2] = 4, 0.0
        if s == nan_at:
            p[5][0] = math.nan
        for k, name in enumerate(NAMES):
            if f"{name}_dyn" in ctx.deactivated:      # the master: a removed UAV's outputs keep their values
                continue
            ctx.set(name, x=p[k][0], y=p[k][1], z=p[k][2], phase=phase[k])
        ctx.set("u5", mission_state=1 if s < ms_at else 2, photo_count=s // 40)
    return h, steps, load


def _monitor(mode):
    mon = UavMonitor(annotation(NAMES, zones=[("box", ZONE)]), None, "native.ssp")
    mon.native = mode == "native"
    mon.precheck = mode != "exact"
    return mon


STATE = ("_dist", "_dist_xy", "_ftime", "_took_off", "_trav", "_ztrav", "_zclear", "_zfails", "_fails", "_clear",
         "_idle", "last_time")


def _state(mon):
    mon.sync()
    st = [repr(getattr(mon, a)) for a in STATE]           # repr: bit-exact floats, NaN-safe
    st += [mon.p0.tobytes(), repr(mon._idle_fly if mon._idle else None), len(mon.track_t)]
    return st


def _outputs(mon, ctx):
    mon.sync()
    mon._track(mon.last_time, mon.p0, mon.ph0, force=True)
    return (repr(ctx.events), repr(ctx.deactivated), repr([dataclasses.asdict(r) for r in mon.records]),
            repr(mon.track_t), np.stack(mon.track_p).tobytes(), np.stack(mon.track_phase).tobytes())


def _run(seed, mode, each_step=None):
    h, steps, load = fleet(seed)
    mon, ctx = _monitor(mode), FakeCtx(NAMES)
    load(ctx, 0)
    mon.attach(ctx, 0.0)
    codes = []
    if mon._native is not None:
        step = mon._native.step

        def counted(t0, t1):
            codes.append(step(t0, t1))
            return codes[-1]
        mon._native.step = counted
    for s in range(1, steps + 1):
        load(ctx, s)
        mon.after_step(s - 1, h * (s - 1), h * s)
        if each_step is not None:
            each_step(s, mon)
    return mon, ctx, codes


@pytest.mark.parametrize("seeds,backend", [(range(0, 12), "default"), (range(12, 24), "default"),
                                           (range(24, 30), "ctypes")])
def test_c_step_equals_the_python_step_bit_for_bit_after_every_step(seeds, backend, monkeypatch):
    """Both ways of calling the C step: the extension module when Python's headers are there (the default
    here), and ctypes (the fallback)."""
    if backend == "ctypes":
        fn = monitor_native.ctypes_step()
        assert fn[0] is not None, fn[1]
        monkeypatch.setattr(monitor_native, "step_function", lambda: fn)
    done = 0
    for seed in seeds:
        ref = []
        _run(seed, "python", lambda s, mon: ref.append(_state(mon)))
        got = []
        mon, _, codes = _run(seed, "native", lambda s, mon: got.append(_state(mon)))
        assert mon._native is not None
        for s, (a, b) in enumerate(zip(ref, got)):
            assert a == b, (seed, s + 1, [STATE[i] for i in range(len(STATE)) if a[i] != b[i]])
        done += codes.count(monitor_native.MS_DONE)
        assert monitor_native.MS_PYTHON in codes       # Python steps between the C ones
    assert done > 0.7 * 160 * len(seeds)               # C did most steps


def test_c_step_python_step_and_exact_checks_give_identical_runs():
    kinds, gaps_hit = set(), 0
    for seed in range(40):
        outs = {}
        for mode in ("exact", "python", "native"):
            mon, ctx, _ = _run(seed, mode)
            outs[mode] = _outputs(mon, ctx)
        for mode in ("python", "native"):
            for what, a, b in zip(("events", "deactivated", "records", "track_t", "track_p", "track_phase"),
                                  outs["exact"], outs[mode]):
                assert a == b, (seed, mode, what)
        events = eval(outs["exact"][0], {"nan": math.nan})
        kinds |= {e["type"] for e in events}
        gaps_hit += sum(e["type"] == "uav" for e in events)
    # not vacuous: contacts (gaps < 0) and zone incursions happened, and near misses did not all collide
    assert {"uav", "zone", "mission"} <= kinds
    assert 10 < gaps_hit < 2 * 2 * 40 * 0.9


def test_near_miss_construction_is_what_the_exact_check_sees():
    """The fleet's pairs: a contact exactly when the constructed gap is <= 0 (up to 1e-6 m of rounding)."""
    rng = np.random.default_rng(7)
    from uavstudy.geometry import CollisionDetector
    det = CollisionDetector(D)
    for _ in range(300):
        a, b, gap = _near_miss(rng, 100.0)
        if abs(gap) < 1e-6:
            continue
        ts = np.arange(0.0, 100.0 + 1e-9, 0.5)
        hit = any(det.check_bruteforce(t0, t1, np.array([a(t0), b(t0)]), np.array([a(t1), b(t1)]))
                  for t0, t1 in zip(ts[:-1], ts[1:]))
        assert hit == (gap < 0), gap


def test_pure_python_switch(monkeypatch):
    monkeypatch.setenv("UAVSTUDY_PURE_PYTHON", "1")
    mon, ctx, codes = _run(0, "native")
    assert mon._native is None and codes == []
