"""UavWind (uavsim.wind): the paper's stochastic wind, Dryden turbulence, 1-cosine gusts."""
import math

import numpy as np
import pytest

from uavsim.wind import Wind, WindParams, dryden_low_altitude


def sample(params, h, t_end, every=1.0):
    w = Wind(params)
    out = []
    n = int(round(t_end / h))
    for i in range(n + 1):
        t = i * h
        if abs(t / every - round(t / every)) < 1e-9:
            out.append(w.at(t))
    return np.array(out)


FULL = dict(probability=0.4, turbulence=True, gusts=True)


def test_same_seed_bit_identical_other_seed_differs():
    a = sample(WindParams(seed=7, **FULL), 0.5, 500)
    b = sample(WindParams(seed=7, **FULL), 0.5, 500)
    c = sample(WindParams(seed=8, **FULL), 0.5, 500)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_master_step_independence():
    # random numbers are drawn per decision interval and turbulence lives on a fixed 0.1 s grid:
    # the output at a given time does not depend on the master step
    ref = sample(WindParams(seed=3, **FULL), 1.0, 300)
    for h in (0.05, 0.1, 0.25, 0.5):
        assert np.array_equal(sample(WindParams(seed=3, **FULL), h, 300), ref)


def test_probability_zero_and_occurrence_rate():
    assert not sample(WindParams(probability=0.0, seed=1), 1.0, 300).any()
    # p = 0.15 over 4000 intervals: expected 600 episodes, sd sqrt(4000*.15*.85) = 22.6 -> +-4 sd
    w = Wind(WindParams(probability=0.15, seed=11))
    n = sum(1 for k in range(4000) if w.level_at(k * 10.0 + 5.0)[0] > 0)
    assert abs(n - 600) < 91


def test_levels_speeds_and_east_to_west_direction():
    # p = 1: every interval has wind; level 1/2/3 each with probability 1/3:
    # 3000 intervals -> 1000 +- 4 sd (sd = sqrt(3000 * 1/3 * 2/3) = 25.8)
    w = Wind(WindParams(probability=1.0, seed=5))
    counts = {1: 0, 2: 0, 3: 0}
    speed = {1: 4.0, 2: 7.0, 3: 11.0}          # Beaufort 3 / 4 / 6 representative speeds
    for k in range(3000):
        wx, wy, wz, lvl = w.at(k * 10.0 + 5.0)   # mid-episode (after the 1 s ramp)
        counts[lvl] += 1
        # default direction_deg = 90 (from the east): the air moves west, w = (-U, 0, 0)
        assert wx == pytest.approx(-speed[lvl]) and abs(wy) < 1e-12 and wz == 0.0
    for c in counts.values():
        assert abs(c - 1000) < 104


def test_direction_convention_from_north():
    # direction_deg = 0: wind FROM the north blows toward the south: w = (0, -U)
    wx, wy, _, lvl = Wind(WindParams(probability=1.0, seed=5, direction_deg=0.0)).at(5.0)
    assert abs(wx) < 1e-12 and wy < 0 and lvl > 0


def test_ramp_and_duration():
    # duration 6 s, ramp 1 s: U(kT + 0.5) = U/2, U(kT + 3) = U, U(kT + 7) = 0
    w = Wind(WindParams(probability=1.0, seed=2, duration=6.0))
    lvl, u_mid = w.level_at(3.0)
    assert w.level_at(0.5)[1] == pytest.approx(u_mid / 2)
    assert w.level_at(5.5)[1] == pytest.approx(u_mid / 2)
    assert w.level_at(7.0) == (0, 0.0)


def test_dryden_scales_hand_values():
    # h = 20 m = 65.62 ft: f = 0.177 + 0.000823 * 65.62 = 0.23100; sigma_w = 0.1 * 11 = 1.1;
    # sigma_u = 1.1 / f^0.4 = 1.1 / 0.55647 = 1.9767; L_u = 65.62 / f^1.2 ft = 380.8 ft = 116.06 m
    (su, sv, sw), (lu, lv, lw) = dryden_low_altitude(11.0, 20.0)
    assert sw == pytest.approx(1.1)
    assert su == pytest.approx(1.9767, rel=1e-3) and sv == su
    assert lu == pytest.approx(116.06, rel=1e-3) and lw == pytest.approx(20.0)


def test_turbulence_variance_matches_dryden_sigma():
    # samples at mid-episode of 2000 independent strong-wind episodes: the along-wind deviation
    # from the mean U = 11 m/s has standard deviation sigma_u = 1.977 (std error ~1.6 %)
    w = Wind(WindParams(probability=1.0, seed=9, turbulence=True, p_weak=0.0, p_moderate=0.0))
    u = np.array([-w.at(k * 10.0 + 5.0)[0] - 11.0 for k in range(2000)])
    vz = np.array([w.at(k * 10.0 + 5.05)[2] for k in range(2000)])
    assert abs(u.mean()) < 0.15
    assert u.std() == pytest.approx(1.977, rel=0.07)
    assert vz.std() == pytest.approx(1.1, rel=0.07)


def test_one_minus_cosine_gust_peak():
    # gust amplitude 0.5 U over 2 s: the peak along-wind speed is U (1 + 0.5) = 16.5 m/s for a
    # strong episode whose gust lies on the plateau
    w = Wind(WindParams(probability=1.0, seed=4, gusts=True, p_weak=0.0, p_moderate=0.0))
    peaks = []
    for k in range(50):
        peaks.append(max(-w.at(k * 10.0 + i * 0.01)[0] for i in range(1000)))
    assert max(peaks) == pytest.approx(16.5, abs=1e-3)
    assert min(peaks) >= 11.0


@pytest.mark.parametrize("interval,gust_length", [(1.0, 2.0), (1.0, 1.0), (10.0, 2.0), (0.5, 3.0)])
def test_gust_longer_than_episode_is_clipped_to_it(interval, gust_length):
    # the shipped scenarios decide the wind every 1 s with a 2 s gust: the gust is shortened to the
    # episode (T_g = min(gust_length, D)) and lies wholly inside it; start uniform in [0, D - T_g]
    D = interval
    tg = min(gust_length, D)
    U, amp = 9.0, 0.5
    w = Wind(WindParams(probability=1.0, seed=5, gusts=True, p_weak=0.0, p_moderate=0.0,
                        speed_strong=U, decision_interval=interval, duration=interval, ramp=0.0,
                        gust_length=gust_length, gust_amplitude=amp))
    starts = []
    for k in range(200):
        t0, length = w.gust_window(k)
        assert length == pytest.approx(tg)
        assert k * interval - 1e-12 <= t0 <= k * interval + D - tg + 1e-12
        starts.append((t0 - k * interval) / max(D - tg, 1e-12) if D > tg else 0.0)
        # the wind follows U + A/2 (1 - cos(2 pi s / T_g)) within the window, U outside it
        for s in np.linspace(0.0, 1.0, 21):
            t = t0 + s * tg
            if t - k * interval >= D:       # the next episode starts at the end of this one
                continue
            expect = U + 0.5 * amp * U * (1.0 - math.cos(2.0 * math.pi * s))
            assert -w.at(t)[0] == pytest.approx(expect, abs=1e-9)
        if D > tg:
            assert min(starts) >= 0.0 and max(starts) <= 1.0
    # a full-length gust is reached in every episode: the peak is U (1 + amp)
    peaks = [max(-w.at(k * interval + i * D / 400)[0] for i in range(400)) for k in range(20)]
    assert min(peaks) == pytest.approx(U * (1 + amp), rel=2e-3)
    if D > tg:   # the start is spread over the allowed range
        assert max(starts) - min(starts) > 0.5


def test_gust_inside_short_episode_with_ramp_is_continuous():
    # 1 s decision interval, 0.25 s ramp, 2 s gust (the shipped scenarios with gusts on): the wind
    # is continuous (no jump at the gust or episode edges) and zero between episodes
    w = Wind(WindParams(probability=0.5, seed=11, gusts=True, turbulence=False, decision_interval=1.0,
                        duration=1.0, ramp=0.25, gust_length=2.0))
    h = 1e-4
    xs = np.array([w.at(i * h)[0] for i in range(int(60 / h))])
    assert np.max(np.abs(np.diff(xs))) < 0.1     # <= max slope (~ 1.5 U / ramp) x h
    assert np.max(-xs) > 0.0


def test_calm_step_mean_is_zero_and_draws_stay_in_order():
    # probability 0: no episode can occur, so every step mean is exactly zero (the shortcut draws nothing); the
    # intervals drawn later (gust_window) are those of a wind that drew every interval on the way
    full = dict(turbulence=True, gusts=True, probability=0.0, seed=4)
    lazy, eager = Wind(WindParams(**full)), Wind(WindParams(**full))
    for k in range(300):
        t = 0.1 * k
        assert lazy.mean_over(t, t + 0.1) == (0.0, 0.0, 0.0, 0)
        assert eager.at(t) == (0.0, 0.0, 0.0, 0)
    assert [lazy.gust_window(k) for k in range(40)] == [eager.gust_window(k) for k in range(40)]


@pytest.mark.parametrize("extra", [
    dict(turbulence=True, gusts=True),
    dict(turbulence=False, gusts=True, decision_interval=1.0, duration=1.0, ramp=0.25, gust_length=2.0),
    dict(turbulence=True, gusts=False, ramp=0.0, duration=4.0),
    dict(turbulence=False, gusts=False, direction_deg=37.0, duration=3.3, ramp=0.7),
    dict(turbulence=True, gusts=True, probability=0.1, decision_interval=1.0, duration=1.0, ramp=0.25),
])
def test_step_mean_is_bitwise_the_mean_of_its_samples(extra):
    # mean_over writes at(t) out inline for speed; its definition is the midpoint mean of at(t) over m samples of
    # at most 0.05 s, summed in order (Wind._mean_of_samples): both must give the same bits, level included, for
    # steps that straddle episode edges, ramps, gusts and turbulence grid points, forwards and after a restart
    rng = np.random.default_rng(19)
    params = WindParams(**{"probability": 0.5, "seed": 23, **extra})
    fast, ref = Wind(params), Wind(params)
    t, windy = 0.0, 0
    for _ in range(3000):
        h = float(rng.choice([0.05, 0.1, 0.25, 0.3, 1.0, rng.uniform(0.001, 2.5)]))
        t1 = t + h
        m = min(200, max(1, int(math.ceil((t1 - t) / 0.05 - 1e-9))))
        got, want = fast.mean_over(t, t1), ref._mean_of_samples(t, t1 - t, m)
        assert got == want and [math.copysign(1.0, v) for v in got[:3]] == [math.copysign(1.0, v) for v in want[:3]]
        windy += got[3] > 0
        t = t + h if rng.random() > 0.02 else float(rng.uniform(0.0, t))    # now and then back in time
    assert windy > 100


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
        assert np.array_equal(on.intervals[k].noise, rng.standard_normal((on.n_turb + 1, 3)))
