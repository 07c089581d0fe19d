"""The UAV-to-UAV channel (uavsim/channel.py): range, period, latency, loss, k nearest, line of sight, silence,
determinism.  Expectations are derived from the parameters by hand (which pairs are in range, which step holds
an arrival instant) and, for the loss, from the binomial distribution."""
import math

import numpy as np
import pytest
from uavsim import channel as C


@pytest.fixture(autouse=True, params=["python", "compiled"])
def channel_step(request, monkeypatch):
    """Every test twice: with the Python step (the reference) and with the compiled step of the UavChannel FMU
    (uavsim/_channel_ext.c, which must take every broadcast these tests make: a decline fails the test)."""
    if request.param == "compiled":
        from uavsim.accelerators import CHANNEL_STEP
        ext, why = CHANNEL_STEP.load()
        if ext is None:
            pytest.skip(f"the compiled channel step is not available here: {why}")
        fields = C.BROADCAST_REAL + C.BROADCAST_INT

        def step(self, t, h, broadcasts):
            names = [tuple(f"uav{i}_{f}" for f in fields) for i in range(self.n)]
            variables = {f"uav{i}_{f}": b[f] for i, b in enumerate(broadcasts) for f in fields}
            out = ext.advance(self, t, h, variables, names)
            assert out is not NotImplemented, "the compiled step declined"
            return out if out is not None else [[] for _ in range(self.n)]
        monkeypatch.setattr(C.Channel, "step", step)
    return request.param


def _bc(x, y, z=20.0, clock=0.0, state=2, target=-1, claims=(), visited=()):
    c0, c1 = C.encode_mask(claims)
    v0, v1 = C.encode_mask(visited)
    return {"x": x, "y": y, "z": z, "vx": 0.0, "vy": 0.0, "wx": x, "wy": y, "clock": clock, "state": state,
            "target": target, "claims0": c0, "claims1": c1, "visited0": v0, "visited1": v1}


def _run(params, positions, steps, h=0.1, t0=0.0):
    """Step a channel with UAVs standing at ``positions``; yields (t, deliveries) per step."""
    ch = C.Channel(params)
    for n in range(steps):
        t = t0 + n * h
        yield ch, t, ch.step(t, h, [_bc(x, y, clock=t) for x, y in positions])


def _field(message, name):
    return message[(C.MESSAGE_REAL + C.MESSAGE_INT).index(name)]


def test_mask_round_trip_covers_sign_bits():
    for indices in ([], [0], [31], [32], [63], [0, 5, 31, 32, 40, 63], list(range(64))):
        words = C.encode_mask(indices)
        assert all(-2 ** 31 <= w < 2 ** 31 for w in words)      # FMI Integer (int32)
        assert C.decode_mask(*words) == set(indices)
    with pytest.raises(ValueError):
        C.encode_mask([64])


def test_range_is_respected_and_inclusive():
    # receiver 0 at the origin; senders at 100, 200 (exactly the range), 200.5 m
    pos = [(0.0, 0.0), (100.0, 0.0), (0.0, 200.0), (200.5, 0.0)]
    params = C.ChannelParams(range=200.0, period=1.0, k=8, n_uavs=4)
    got = {}
    for _, t, out in _run(params, pos, 10):
        for m in out[0]:
            got.setdefault(_field(m, "sender"), []).append(t)
    assert sorted(got) == [1, 2]
    # one message per period from each sender in range: at t = 0 and 1.0 (10 steps of 0.1 s)
    assert [len(v) for v in got.values()] == [1, 1]


def test_latency_puts_each_arrival_in_the_step_holding_its_instant():
    h = 0.1
    for latency in (0.0, 0.05, 0.3, 0.35, 1.25):
        params = C.ChannelParams(range=1e3, period=0.5, latency=latency, k=4, n_uavs=2)
        arrivals = []
        for _, t, out in _run(params, [(0.0, 0.0), (10.0, 0.0)], 60, h=h):
            arrivals += [(t, _field(m, "sent_time")) for m in out[1]]
        assert len(arrivals) == len([n for n in range(12) if n * 0.5 + latency < 6.0 - 1e-9])
        for t, sent in arrivals:
            assert t - 1e-9 <= sent + latency < t + h - 1e-9, (latency, t, sent)
        # the measured latency (step start - sending) is the parameter rounded down to the step grid
        delays = [t - sent for t, sent in arrivals]
        assert max(delays) - min(delays) < 1e-9
        assert delays[0] == pytest.approx(math.floor(latency / h + 1e-9) * h)


def test_loss_rate_matches_the_parameter_within_the_binomial_tolerance():
    # 8 UAVs in range of each other, one broadcast per step: 8 * 7 = 56 pair trials per step
    n, steps = 8, 500
    pos = [(10.0 * i, 0.0) for i in range(n)]
    for loss in (0.05, 0.3, 0.8):
        params = C.ChannelParams(range=1e3, period=0.1, loss=loss, k=8, n_uavs=n, seed=7)
        received = 0
        for ch, _, out in _run(params, pos, steps):
            received += sum(len(m) for m in out)
        trials = n * (n - 1) * steps
        assert ch.counters["lost"] + ch.counters["received"] == trials
        # each trial is lost independently with probability p: the count is Binomial(trials, p); 5 standard
        # deviations leave a correct generator a chance of failing below 1e-6 for any seed
        sigma = math.sqrt(trials * loss * (1 - loss))
        assert abs(ch.counters["lost"] - loss * trials) < 5 * sigma, (loss, ch.counters["lost"], trials)
        # and per receiver (7 * 500 trials each)
        per = ch.uav_counters["lost"]
        sigma_r = math.sqrt((n - 1) * steps * loss * (1 - loss))
        assert all(abs(x - loss * (n - 1) * steps) < 5 * sigma_r for x in per)


def test_loss_draws_are_independent_of_pairs_and_message_numbers():
    # the fraction lost on two consecutive messages of the same pair is p^2 (no correlation along a link)
    p, numbers = 0.4, np.arange(20000)
    u = np.array([C.uniform(3, 1, 2, int(k)) for k in numbers])
    lost = u < p
    both = np.mean(lost[1:] & lost[:-1])
    sigma = math.sqrt(p * p * (1 - p * p) / (len(numbers) - 1))
    assert abs(both - p * p) < 5 * sigma
    # the scalar draw equals the array draw: the order of evaluation does not matter
    senders, receivers = np.arange(5)[:, None], np.arange(5)[None, :]
    grid = C.uniform(11, senders, receivers, 9)
    assert all(grid[s, r] == C.uniform(11, s, r, 9) for s in range(5) for r in range(5))


def test_k_nearest_first_and_the_rest_counted_as_overflow():
    pos = [(0.0, 0.0), (50.0, 0.0), (0.0, 10.0), (-30.0, 0.0), (0.0, -70.0), (20.0, 0.0)]
    params = C.ChannelParams(range=1e3, period=1.0, k=3, n_uavs=6)
    ch, _, out = next(_run(params, pos, 1))
    assert [_field(m, "sender") for m in out[0]] == [2, 5, 3]           # 10, 20, 30 m
    assert all(len(o) == 3 for o in out)
    assert ch.counters["overflow"] == 6 * (5 - 3)
    assert ch.counters["received"] == 18


def test_equal_distances_break_ties_by_the_lower_sender():
    pos = [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (-10.0, 0.0)]
    _, _, out = next(_run(C.ChannelParams(range=1e3, k=2, n_uavs=4), pos, 1))
    assert [_field(m, "sender") for m in out[0]] == [1, 2]


def test_several_instants_arriving_in_one_step_are_ordered_by_distance_then_sender_then_arrival():
    # period 0.04 s in steps of 0.1 s, no latency: instants 0, 0.04, 0.08 all arrive in [0, 0.1).  Senders 1 and 2
    # both 10 m from receiver 0 (a tie), sender 3 at 30 m: 9 messages for receiver 0, k = 4 of them taken
    pos = [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (0.0, -30.0)]
    ch, _, out = next(_run(C.ChannelParams(range=1e3, period=0.04, k=4, n_uavs=4), pos, 1))
    assert [(_field(m, "sender"), _field(m, "sent_time")) for m in out[0]] == \
        [(1, 0.0), (1, 1 * 0.04), (1, 2 * 0.04), (2, 0.0)]
    assert ch.counters["sent"] == 3 * 4
    assert ch.counters["overflow"] == 4 * (3 * 3 - 4)
    assert ch.counters["received"] == 4 * 4


def test_restricted_zone_blocks_the_line_of_sight():
    wall = [[(40.0, -50.0), (60.0, -50.0), (60.0, 50.0), (40.0, 50.0)]]
    pos = [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0)]
    for los, expect in ((True, [2]), (False, [1, 2])):
        params = C.ChannelParams(range=1e3, k=4, n_uavs=3, line_of_sight=los, zones=wall)
        ch, _, out = next(_run(params, pos, 1))
        assert sorted(_field(m, "sender") for m in out[0]) == expect
    assert ch.counters["blocked"] == 0
    ch = C.Channel(C.ChannelParams(range=1e3, k=4, n_uavs=3, line_of_sight=True, zones=wall))
    ch.step(0.0, 0.1, [_bc(x, y) for x, y in pos])
    assert ch.counters["blocked"] == 4          # 0 <-> 1 and 1 <-> 2 (x + y = 100 cuts the wall at x > 50)


def test_baselines_none_and_perfect():
    pos = [(0.0, 0.0), (5000.0, 0.0)]
    none = C.ChannelParams(mode="none", range=1e4, n_uavs=2)
    for ch, _, out in _run(none, pos, 30):
        assert out == [[], []]
    assert ch.counters["sent"] == 0 and ch.counters["received"] == 0
    # perfect: unlimited range, no loss, no latency, whatever the radio parameters say
    perfect = C.ChannelParams(mode="perfect", range=1.0, loss=1.0, latency=5.0, n_uavs=2)
    ch, _, out = next(_run(perfect, pos, 1))
    assert [len(o) for o in out] == [1, 1] and ch.counters["lost"] == 0


def test_a_uav_whose_strategy_stopped_falls_silent():
    ch = C.Channel(C.ChannelParams(range=1e3, period=0.1, k=4, n_uavs=2))
    got = []
    for n in range(20):
        t = 0.1 * n
        # UAV 1's clock stops at step 5 (removed after a collision: its strategy no longer steps)
        out = ch.step(t, 0.1, [_bc(0.0, 0.0, clock=t), _bc(10.0, 0.0, clock=min(t, 0.4))])
        got.append(len(out[0]))
    assert got == [1] * 5 + [0] * 15
    assert ch.uav_counters["sent"] == [20, 5]


def test_message_carries_the_broadcast():
    ch = C.Channel(C.ChannelParams(range=1e3, k=4, n_uavs=2))
    b1 = dict(_bc(3.0, 4.0, z=21.0, state=4, target=17, claims=[1, 40], visited=[63]), vx=1.5, vy=-2.0, wx=9.0,
              wy=-9.0)
    out = ch.step(0.0, 0.1, [_bc(0.0, 0.0), b1])
    (m,) = out[0]
    assert dict(zip(C.MESSAGE_REAL + C.MESSAGE_INT, m)) == {
        "x": 3.0, "y": 4.0, "z": 21.0, "vx": 1.5, "vy": -2.0, "wx": 9.0, "wy": -9.0, "sent_time": 0.0,
        "sender": 1, "state": 4, "target": 17, "claims0": b1["claims0"], "claims1": b1["claims1"],
        "visited0": 0, "visited1": b1["visited1"]}
    assert C.decode_mask(m[-4], m[-3]) == {1, 40}


def test_near_misses_count_each_encounter_once():
    ch = C.Channel(C.ChannelParams(mode="none", n_uavs=2, near_miss=10.0))
    # UAV 1 passes UAV 0 twice: 30 m -> 5 m -> 30 m -> 8 m -> 30 m
    for t, d in enumerate([30, 20, 5, 6, 30, 8, 9, 30]):
        ch.step(float(t), 1.0, [_bc(0.0, 0.0, clock=t), _bc(float(d), 0.0, clock=t)])
    assert ch.counters["near_misses"] == 2


def test_same_seed_same_deliveries_bit_for_bit_other_seed_differs():
    rng = np.random.default_rng(1)
    pos = [tuple(p) for p in rng.uniform(-150, 150, size=(10, 2))]

    def trace(seed):
        out = []
        for _, t, d in _run(C.ChannelParams(range=200.0, period=0.3, latency=0.2, loss=0.25, k=3, n_uavs=10,
                                            seed=seed), pos, 80):
            out.append(repr(d))
        return out
    assert trace(5) == trace(5)
    assert trace(5) != trace(6)


@pytest.mark.parametrize("bad", [dict(mode="wifi"), dict(k=0), dict(loss=1.5), dict(period=0.0), dict(n_uavs=0),
                                 dict(latency=-1.0)])
def test_bad_parameters_are_refused(bad):
    with pytest.raises(ValueError):
        C.Channel(C.ChannelParams(**bad))
