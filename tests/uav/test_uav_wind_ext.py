"""The FMU step of UavWind in C (uavsim/_wind_ext.c) against the Python step of the same shell run with
COSIM_MASTER_PURE_PYTHON=1, bit for bit: the published outputs and the whole model state (drawn intervals, random
generators, calm window), over thousands of random wind parameters and steps -- calm and windy intervals, episode
ramps and boundaries, gusts, probabilities 0 and 1, steps of 1 to 200 samples, times going back -- and over whole
runs of the shipped FMUs.  Where the extension declines a step (a random draw, turbulence, a step before time 0)
it must have changed nothing."""
import math
import random
from collections import Counter

import numpy as np
import pytest
from bitwise import bits
from build_script import load_shell
from shipped_extension_runs import run_with_and_without_extensions

from uavsim.wind import Wind, WindParams

OUTPUTS = ("wind_x", "wind_y", "wind_z", "wind_speed", "wind_level")


@pytest.fixture(scope="module")
def ext(extensions_folder):
    """The extension compiled here, as build_fmus.py compiles it for the FMUs."""
    from uavsim import native
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("COSIM_MASTER_PURE_PYTHON", raising=False)
        module = native.load_extension("_wind_ext", extensions_folder)
    assert module is not None, "the extension did not load"
    return module


def snapshot(shell):
    """The shell's outputs and its Wind model's whole state, as comparable bits."""
    return bits([(n, getattr(shell, n)) for n in OUTPUTS]), bits(vars(shell._model))


def outputs(shell):
    """What a step may change: the outputs, the calm window and how many intervals are drawn (the intervals
    themselves only grow; snapshot compares them)."""
    m = shell._model
    return bits([getattr(shell, n) for n in OUTPUTS] + [m._calm, m._next_k, len(m._occurs), len(m._intervals)])


def identities(shell):
    """Which objects the shell and its model hold (a declined step must not replace any)."""
    return [id(v) for v in vars(shell).values()], [id(v) for v in vars(shell._model).values()], outputs(shell)


def make_pair(ext, **params):
    """(shell stepping in C, shell stepping in pure Python), same parameters; the C one counts its outcomes and
    checks that a declined step changed nothing."""
    shells = []
    for pure in (False, True):
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("COSIM_MASTER_PURE_PYTHON", "1") if pure else mp.delenv("COSIM_MASTER_PURE_PYTHON", raising=False)
            s = load_shell("UavWind")
        for k, v in params.items():
            setattr(s, k, v)
        s.setup_experiment(0.0, None, None)
        s.exit_initialization_mode()
        shells.append(s)
    a, b = shells
    assert b._ext is None
    outcomes = Counter()

    def counted(d, t, h):
        before = identities(a)
        done = ext.step(d, t, h)
        if done:
            outcomes["windy" if a.wind_level else "calm"] += 1
            outcomes["gusty"] += bool(a.wind_level and a.gusts)
        else:
            outcomes["declined"] += 1
            assert identities(a) == before, "a declined step changed the shell"
        return done
    a._ext = counted
    return a, b, outcomes


def random_params(rng):
    di = rng.choice([10.0, 10.0, 2.5, 0.7, 1.0, rng.uniform(0.3, 12.0)])
    return dict(
        probability=rng.choice([0.0, 1.0, 0.15, 0.5, 0.025, rng.random(), -0.0, 1e-300]),
        seed=rng.randrange(1 << 31), stream=rng.choice([-1, 0, 3]),
        decision_interval=di,
        duration=rng.choice([di, di, 0.5 * di, 2.0 * di, rng.uniform(0.1, di)]),
        ramp=rng.choice([min(1.0, 0.25 * di), 0.0, rng.uniform(0.0, di), 2.0 * di]),
        speed_weak=rng.choice([4.0, 0.0, rng.uniform(0.1, 20.0)]),
        speed_moderate=rng.choice([7.0, rng.uniform(0.1, 20.0)]),
        speed_strong=rng.choice([11.0, rng.uniform(0.1, 20.0)]),
        direction_deg=rng.choice([90.0, 0.0, 45.0, rng.uniform(-360.0, 360.0)]),
        gusts=rng.random() < 0.4,
        gust_length=rng.choice([2.0, 0.0, di, 3.0 * di, rng.uniform(0.0, di)]),
        gust_amplitude=rng.choice([0.3, rng.uniform(0.0, 2.0)]),
        turbulence=rng.random() < 0.1)


def random_steps(rng, di, n):
    """(current_time, step_size) pairs: fixed steps on and off episode boundaries, steps whose first sample falls
    on a boundary (within the rounding of t / T), long and tiny steps, jumps back to intervals drawn already and a
    few before time 0."""
    h = rng.choice([0.25, 0.25, 0.1, 0.5, 1.0, rng.uniform(0.01, 3.0), 0.05, 0.049999999, 12.0, 1e-7])
    t = rng.choice([0.0, -h, -2.5 * h, rng.uniform(0.0, 50.0)])
    for _ in range(n):
        r = rng.random()
        if r < 0.08:
            t = rng.randrange(0, 12) * di - h + rng.choice([0.0, 1e-12, -1e-12, 1e-9, -1e-9, 0.5 * h])
        elif r < 0.13:
            m = min(200, max(1, math.ceil(h / 0.05 - 1e-9)))       # mean_over's sample count
            t = rng.randrange(1, 12) * di - h - 0.5 * h / m + rng.choice([0.0, 0.0, 1e-15, -1e-15, 4e-15])
        elif r < 0.18:
            t = rng.uniform(-2.0 * h, 30.0 * di)
        elif r < 0.21:
            h = rng.choice([0.25, rng.uniform(1e-6, 25.0), 0.05, 9.9999, 60.0])
        yield t, h
        t += h


def outcome(shell, t, h):
    """do_step's result, or the error it raised (the Python wind before time 0 may look up interval -1)."""
    try:
        return shell.do_step(t, h)
    except KeyError as exc:
        return repr(exc)


def test_step_matches_python_on_random_winds_and_steps(ext):
    rng = random.Random(20261127)
    total = Counter()
    for case in range(400):
        params = random_params(rng)
        a, b, outcomes = make_pair(ext, **params)
        for t, h in random_steps(rng, params["decision_interval"], 60):
            assert outcome(a, t, h) == outcome(b, t, h)
            assert outputs(a) == outputs(b), (case, params, t, h)
        assert snapshot(a) == snapshot(b), (case, params)
        total.update(outcomes)
    # the extension did the calm and the windy steps, with and without gusts, and left some to Python
    assert total["calm"] > 8000 and total["windy"] > 4000 and total["gusty"] > 1000 and total["declined"] > 300, total


def test_campaign_steps_match_python(ext):
    # the paper campaign's wind: 10 s episodes with 1 s ramps, 0.25 s steps, probabilities 0 ... 0.15, per UAV
    total = Counter()
    for seed in range(8):
        for i, probability in enumerate((0.0, 0.025, 0.075, 0.15, 1.0)):
            params = dict(probability=probability, seed=2021 + seed, stream=i - 1, decision_interval=10.0,
                          duration=10.0, ramp=1.0)
            a, b, outcomes = make_pair(ext, **params)
            for n in range(1200):
                assert a.do_step(n * 0.25, 0.25) and b.do_step(n * 0.25, 0.25)
                assert outputs(a) == outputs(b), (params, n)
            assert snapshot(a) == snapshot(b), params
            total.update(outcomes)
    assert total["windy"] > 10000 and total["declined"] < 0.03 * sum(total.values()), total


def test_fmu_state_restores_through_the_extension(ext):
    a, b, _ = make_pair(ext, probability=0.5, seed=9, gusts=True, decision_interval=2.5, duration=2.0, ramp=0.5)
    for n in range(40):
        a.do_step(n * 0.25, 0.25)
    saved = a._get_fmu_state()
    first = []
    for n in range(40, 120):
        a.do_step(n * 0.25, 0.25)
        first.append(snapshot(a))
    a._set_fmu_state(saved)
    again = []
    for n in range(40, 120):
        a.do_step(n * 0.25, 0.25)
        again.append(snapshot(a))
    for n in range(0, 120):
        b.do_step(n * 0.25, 0.25)
        if n >= 40:
            assert snapshot(b) == first[n - 40]
    assert first == again


def test_declines_without_a_model_or_a_step_mean(ext):
    s = load_shell("UavWind")
    s.probability = 1.0
    d = dict(s.__dict__)
    assert not ext.step(s.__dict__, 0.0, 0.25) and s.__dict__ == d           # no model yet: _build in Python
    s.exit_initialization_mode()
    s.step_mean = False
    assert not ext.step(s.__dict__, 0.0, 0.25)                                 # the wind at a point: at(t)
    s.step_mean = True
    for t, h in ((0.0, 0.0), (0.0, -0.25), (1, 0.25), (0.0, float("nan")), (float("inf"), 0.25)):
        assert not ext.step(s.__dict__, t, h)
    with pytest.raises(TypeError):
        ext.step(s.__dict__, 0.0)


def test_pure_python_switch_disables_the_extension(monkeypatch):
    from uavsim import native
    monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    assert native.load_extension("_wind_ext") is None
    assert load_shell("UavWind")._ext is None


def test_shipped_fmus_run_identically_with_and_without_the_extension(tmp_path, monkeypatch):
    # the FMUs as shipped (their own compiled extensions) against COSIM_MASTER_PURE_PYTHON=1, in-process, 4 UAVs in a
    # wind made frequent (the shipped scenario's is calm) so that episodes come and go within the run
    fast, pure = run_with_and_without_extensions(tmp_path, monkeypatch, ("UavWind",), 1, params={"wind.probability": 0.5},
                                                 stop_time=200.0, step=0.25, record=["*"], record_interval=0.25)
    assert fast.frame.equals(pure.frame)
    assert len(fast.frame) > 500
    assert (fast.frame.filter(like="wind_level") > 0).any().any()


def test_turbulence_stream_is_drawn_only_with_turbulence():
    # without turbulence the wind skips the turbulence stream (it feeds nothing else): every interval's episode and
    # gust numbers, hence every output, are those of the same wind with turbulence on, whose noise is unchanged
    base = dict(probability=0.4, seed=17, stream=2, gusts=True)
    off, on = Wind(WindParams(**base)), Wind(WindParams(turbulence=True, **base))
    for k in range(200):
        a, b = off._interval(k), on._interval(k)
        assert (a.occurs, a.level, a.speed, a.gust_start) == (b.occurs, b.level, b.speed, b.gust_start)
        assert a.noise is None and b.noise.shape == (on.n_turb + 1, 3)
    # the noise of interval k is the k-th block of the turbulence stream, as before
    ss = np.random.SeedSequence((17, 3))
    rng = np.random.Generator(np.random.PCG64(ss.spawn(3)[2]))
    for k in range(200):
        assert np.array_equal(on._intervals[k].noise, rng.standard_normal((on.n_turb + 1, 3)))
