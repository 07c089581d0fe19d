"""The FMU steps of UavDynamics and UavBattery in C (uavsim/_dynamics_ext.c, uavsim/_battery_ext.c) against the
Python step of the same shells run with COSIM_MASTER_PURE_PYTHON=1 (Python kernels, no extension), bit for bit: the
published outputs and the whole model state, over thousands of random states and inputs and over whole flights."""
import random
from collections import Counter

import pytest
from bitwise import bits
from build_script import load_shell
from shipped_extension_runs import run_with_and_without_extensions


NAMES = ("_dynamics_ext", "_battery_ext")
DYN_OUT = ("x", "y", "z", "vx", "vy", "vz", "airspeed", "groundspeed", "tilt", "phase", "ready", "lat", "lon", "alt")
BAT_OUT = ("soc", "consumed", "voltage", "current", "power", "energy_used", "depleted")
CODE = ("kernels", "_fly", "_step")        # the twins' kernels differ by construction; their state does not


@pytest.fixture(scope="session")
def extensions(extensions_folder):
    """The extension modules compiled here, as build_fmus.py compiles them for the FMUs."""
    from uavsim import native
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("COSIM_MASTER_PURE_PYTHON", raising=False)
        mods = {name: native.load_extension(name, extensions_folder) for name in NAMES}
    assert all(mods.values()), "an extension did not load"
    return mods


def snapshot(shell, outputs):
    model = {k: v for k, v in vars(shell._model).items() if k not in CODE}
    return bits([(name, getattr(shell, name)) for name in outputs]), bits(model)


def make_pair(name, extensions, **params):
    """(shell stepping in C, shell stepping in pure Python), same parameters; the C one counts its outcomes."""
    ext = extensions[f"_{name[3:].lower()}_ext"].step
    shells = []
    for pure in (False, True):
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("COSIM_MASTER_PURE_PYTHON", "1") if pure else mp.delenv("COSIM_MASTER_PURE_PYTHON", raising=False)
            s = load_shell(name)
            for k, v in params.items():
                setattr(s, k, v)
            s.exit_initialization_mode()
            shells.append(s)
    a, b = shells
    assert b._ext is None and not b._model.kernels.compiled
    if name == "UavDynamics":            # the C shell's lat/lon/alt getters from the extension compiled here
        module = extensions["_dynamics_ext"]
        type(a).lat, type(a).lon, type(a).alt = type(a).__init__.__globals__["_geodetic_properties"](module)
        assert type(a).lat.fget is module.lat and type(b).lat.fget.__name__ == "<lambda>"
    outcomes = Counter()

    def counted(d, h):
        done = ext(d, h)
        outcomes[done] += 1
        return done
    a._ext = counted
    return a, b, outcomes


# ------------------------------------------------------------------ dynamics

def random_dynamics_state(rng, takeoff_alt):
    phase = rng.choice([0, 1, 2, 2, 2, 3, 3, 4])
    z = {0: 0.0, 4: 0.0, 1: rng.choice([rng.uniform(0.0, takeoff_alt), takeoff_alt - 0.2 - rng.uniform(0.0, 0.05)]),
         2: rng.uniform(0.0, 60.0), 3: rng.choice([rng.uniform(0.0, 0.06), rng.uniform(0.0, 30.0)])}[phase]
    pos = [rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0), z]
    hold = [pos[0], pos[1]] if rng.random() < 0.2 else [rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0)]
    still = rng.random() < 0.15 or phase in (0, 4)

    def u(lo, hi):          # zeros of both signs: still air and no thrust take shortcuts that must not show
        return rng.choice([0.0, -0.0]) if still else rng.uniform(lo, hi)
    elapsed = rng.uniform(0.0, 6.0)
    return dict(pos=pos, vel=[u(-12.0, 12.0), u(-12.0, 12.0), u(-3.0, 3.0)], vt=[u(-12.0, 12.0), u(-12.0, 12.0)],
                vtz=u(-2.5, 2.5), integ=[u(-5.0, 5.0), u(-5.0, 5.0)], hold=hold, hold_z=rng.uniform(0.0, 50.0),
                a_cmd=[u(-6.0, 6.0), u(-6.0, 6.0)], phase=phase, mode=rng.choice(["goto", "hold"]),
                preflight_elapsed=elapsed, ready=elapsed >= 5.0 if rng.random() < 0.8 else rng.random() < 0.5,
                time=rng.uniform(0.0, 1000.0), wind=(rng.uniform(-9, 9), rng.uniform(-9, 9), 0.0))


def random_dynamics_inputs(rng):
    wind = [rng.uniform(-20.0, 20.0) if rng.random() < 0.6 else rng.choice([0.0, -0.0]) for _ in range(3)]
    cmd = rng.choice([0, 1, 2, 2, 3, 3, 2.0, 5, -1])
    return dict(cmd=cmd, sp_x=rng.uniform(-400.0, 400.0), sp_y=rng.uniform(-400.0, 400.0),
                sp_z=rng.uniform(0.0, 60.0), wind_x=wind[0], wind_y=wind[1], wind_z=wind[2])


@pytest.mark.parametrize("push", [False, True])
def test_dynamics_step_matches_python_on_random_states(extensions, push):
    # every phase and transition: preflight (clock, ready), lift-off, takeoff -> fly, goto / hold, land, touch-down
    # within a step, landed, re-takeoff; drag and push wind up to 20 m/s (beyond the hold limit: saturation)
    rng = random.Random(11 + push)
    a, b, outcomes = make_pair("UavDynamics", extensions, wind_push=push)
    transitions = Counter()
    for trial in range(3000):
        state = random_dynamics_state(rng, a._model.params.takeoff_altitude)
        inputs = random_dynamics_inputs(rng)
        dt = rng.choice([0.1, 0.1, 0.25, 0.01, 0.05, 1.0, 0.37, 0.0, -0.1])
        for s in (a, b):
            for k, v in state.items():
                setattr(s._model, k, list(v) if type(v) is list else v)
            s.__dict__.update(inputs)
            s.do_step(trial * 0.1, dt)
        assert snapshot(a, DYN_OUT) == snapshot(b, DYN_OUT), (trial, state, inputs, dt)
        transitions[state["phase"], a._model.phase] += 1
    assert outcomes[True] > 2000          # dt <= 0 (2 in 9) falls back; the extension did the steps, not the fallback
    for pair in [(0, 0), (0, 1), (1, 1), (1, 2), (2, 2), (2, 3), (3, 3), (3, 4), (4, 4), (4, 1), (1, 3)]:
        assert transitions[pair] > 0, pair


@pytest.mark.parametrize("push", [False, True])
def test_dynamics_whole_flight_and_fmu_state(extensions, push):
    # a scripted flight through every phase twice, gusty wind, then FMU get/set state: a restored state replays
    # the same steps bit for bit, and the C shell stays identical to the Python one
    rng = random.Random(3)
    a, b, outcomes = make_pair("UavDynamics", extensions, wind_push=push)
    phases, saved, replay = set(), None, []
    t = 0.0
    for k in range(3200):
        cmd = 0 if t < 3 else 1 if t < 20 else (2 if (t // 7) % 3 else 0) if t < 120 else 3 if t < 200 else 1
        sp = ((t // 15) * 37.0 - 60.0, 80.0 - (t // 11) * 29.0, 20.0 + (t // 20) * 3)
        inputs = dict(cmd=cmd, sp_x=sp[0], sp_y=sp[1], sp_z=sp[2], wind_x=rng.uniform(-11, 3),
                      wind_y=rng.uniform(-4, 4), wind_z=rng.uniform(-1, 1))
        if k == 1500:
            saved = a._get_fmu_state()
        if 1500 <= k < 1700:
            replay.append(inputs)
        for s in (a, b):
            s.__dict__.update(inputs)
            s.do_step(t, 0.1)
        assert snapshot(a, DYN_OUT) == snapshot(b, DYN_OUT), k
        if k == 1699:
            expected = snapshot(a, DYN_OUT)
        phases.add(a.phase)
        t += 0.1
    assert phases == {0, 1, 2, 3, 4} and outcomes[True] >= 3199
    a._set_fmu_state(saved)
    for k, inputs in enumerate(replay):
        a.__dict__.update(inputs)
        a.do_step(150.0 + k * 0.1, 0.1)
    assert snapshot(a, DYN_OUT) == expected


def test_dynamics_falls_back_without_changing_anything(extensions):
    # no model yet, a step size not seen before, dt <= 0, an input float() refuses: False and nothing touched
    step = extensions["_dynamics_ext"].step
    a, _, _ = make_pair("UavDynamics", extensions)
    a._model._sub.clear()
    for dt in (0.1, 0.0, -1.0, float("nan")):
        before = snapshot(a, DYN_OUT)
        assert step(a.__dict__, dt) is False
        assert snapshot(a, DYN_OUT) == before
    a.do_step(0.0, 0.1)                        # the Python step fills the cache: the extension takes over
    assert step(a.__dict__, 0.1) is True
    a.wind_x = "gust"
    before = snapshot(a, DYN_OUT)
    assert step(a.__dict__, 0.1) is False
    assert snapshot(a, DYN_OUT) == before
    with pytest.raises(ValueError):            # the Python step raises what it always raised
        a.do_step(0.0, 0.1)
    a.wind_x, a._model = 0.0, None
    assert step(a.__dict__, 0.1) is False


def test_geodetic_getters_match_python_on_random_positions(extensions):
    # the C getters against EnuFrame.to_geodetic (math module, Python's hypot and float power), bit for bit: origins
    # all over the globe, positions up to 50 km away, zeros of both signs, negative heights; the cache as the Python
    # method keeps it (a repeated read returns the cached value); before initialisation the origin may still change
    from uavsim.geodesy import EnuFrame
    rng = random.Random(5)
    for trial in range(40):
        a, b, _ = make_pair("UavDynamics", extensions, origin_lat=rng.uniform(-89.0, 89.0),
                            origin_lon=rng.uniform(-180.0, 180.0), origin_alt=rng.uniform(-400.0, 4000.0))
        frame = EnuFrame(a.origin_lat, a.origin_lon, a.origin_alt)
        for k in range(250):
            pos = [rng.choice([0.0, -0.0, rng.uniform(-5e4, 5e4), rng.uniform(-50.0, 50.0)]) for _ in range(3)]
            for s in (a, b):
                s.x, s.y, s.z = pos
            got = (a.lat, a.lon, a.alt)
            assert bits(got) == bits(frame.to_geodetic(*pos)) == bits((b.lat, b.lon, b.alt)), (trial, pos)
            assert a.alt is got[2] and bits(a._geo_key) == bits(b._geo_key)
    a, b, _ = make_pair("UavDynamics", extensions)
    for s in (a, b):
        s._frame = None
        s.origin_lat, s.x = 45.0, 12.5
    assert bits((a.lat, a.lon, a.alt)) == bits(EnuFrame(45.0, a.origin_lon, a.origin_alt).to_geodetic(12.5, a.y, a.z))


# ------------------------------------------------------------------ battery

def test_battery_step_matches_python_on_random_states(extensions):
    # every branch: motors off / on (phases 0..4, unknown ones, a float phase), climbing and descending, the OCV
    # table below, inside and above its range, overload (more power than the pack can give), depleted
    rng = random.Random(7)
    a, b, outcomes = make_pair("UavBattery", extensions)
    cap = a._model.params.capacity_c
    seen = Counter()
    for trial in range(4000):
        charge = rng.choice([rng.uniform(0.0, cap), rng.uniform(0.9 * cap, 1.2 * cap), 0.0])
        energy = rng.uniform(0.0, 5e5)
        inputs = dict(airspeed=rng.choice([rng.uniform(0.0, 25.0), rng.uniform(0.0, 400.0), 0.0]),
                      vz=rng.choice([rng.uniform(-5.0, 5.0), 0.0]), phase=rng.choice([0, 1, 2, 3, 4, 5, -1, 2.0]))
        dt = rng.choice([0.1, 0.1, 0.25, 0.01, 1.0, 0.37, 0.0, -0.5])
        for s in (a, b):
            s._model.charge_used, s._model.energy_used = charge, energy
            s.__dict__.update(inputs)
            s.do_step(trial * 0.1, dt)
        assert snapshot(a, BAT_OUT) == snapshot(b, BAT_OUT), (trial, charge, inputs, dt)
        seen["overload"] += a._model.overload
        seen["depleted"] += a.depleted
    assert outcomes[True] > 3000 and seen["overload"] > 0 and seen["depleted"] > 0


def test_battery_falls_back_without_changing_anything(extensions):
    step = extensions["_battery_ext"].step
    a, _, _ = make_pair("UavBattery", extensions)
    a._model._sub.clear()
    before = snapshot(a, BAT_OUT)
    assert step(a.__dict__, 0.1) is False and step(a.__dict__, float("nan")) is False
    assert step(a.__dict__, 0.0) is True       # dt <= 0: nothing to do, done
    assert snapshot(a, BAT_OUT) == before
    a.do_step(0.0, 0.1)
    a.phase = "takeoff"
    before = snapshot(a, BAT_OUT)
    assert step(a.__dict__, 0.1) is False
    assert snapshot(a, BAT_OUT) == before


# ------------------------------------------------------------------ whole FMU runs

def test_pure_python_switch_disables_the_extensions(monkeypatch):
    from uavsim import native
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    assert all(native.load_extension(name) is None for name in NAMES)
    for name in ("UavDynamics", "UavBattery"):
        s = load_shell(name)
        s.exit_initialization_mode()
        assert s._ext is None


def test_shipped_fmus_run_identically_with_and_without_the_extensions(tmp_path, monkeypatch):
    # the FMUs as shipped (their own compiled extensions) against COSIM_MASTER_PURE_PYTHON=1, in-process, 4 UAVs
    fast, pure = run_with_and_without_extensions(tmp_path, monkeypatch, ("UavDynamics", "UavBattery"), 8,
                                                 stop_time=60.0, step=0.1, record=["*"], record_interval=0.1)
    assert fast.frame.equals(pure.frame)
    assert len(fast.frame) > 500
