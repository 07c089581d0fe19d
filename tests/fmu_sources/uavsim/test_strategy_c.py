"""Strategy C (uavsim/cooperative.py) in a plain closed loop with the channel (uavsim/fleet_sim.py): silent channel
= B bit for bit, takeover of a lost UAV's targets only when the news arrived, head-on conflict avoided, and the
allocation rules one by one on hand-made messages."""
import dataclasses

import pytest
from uavsim import channel as CH
from uavsim.cooperative import CooperativeStrategy, CoopParams
from uavsim.fleet_sim import simulate_fleet
from uavsim.strategy import LANDED_BASE, RETURN_DONE, RETURN_LOW, TRANSIT, StrategyParams


def _params(strategy, targets, homes):
    return [StrategyParams(strategy=strategy, uav_index=i, uav_count=len(homes), targets=targets, home_x=h[0],
                           home_y=h[1], cruise_altitude=20.0) for i, h in enumerate(homes)]


def _fingerprint(res):
    return [(tuple(d.pos), tuple(d.vel), s.outputs(), list(s.visited)) for d, s in zip(res.dynamics, res.strategies)]


# ------------------------------------------------------------------------------------------------ B fallback
RING = [(0.0, 5.657), (5.657, 0.0), (0.0, -5.657), (-5.657, 0.0)]
SPREAD = [(164.4, -276.3), (128.0, 275.4), (204.7, 176.6), (138.5, -139.6), (-240.3, -92.8), (300.0, 200.0),
          (-17.0, 467.4), (30.4, -227.7)]


def test_c_on_a_silent_channel_flies_exactly_as_b():
    b = simulate_fleet(_params("B", SPREAD, RING), t_end=400.0)
    c_none = simulate_fleet(_params("C", SPREAD, RING), CH.ChannelParams(mode="none", n_uavs=4), t_end=400.0)
    c_without = simulate_fleet(_params("C", SPREAD, RING), t_end=400.0)
    assert _fingerprint(b) == _fingerprint(c_none) == _fingerprint(c_without)
    assert b.t == c_none.t
    # and the channel (perfect) changes C's flight: messages do reach it
    c_perfect = simulate_fleet(_params("C", SPREAD, RING), CH.ChannelParams(mode="perfect", n_uavs=4), t_end=400.0)
    assert c_perfect.channel.counters["received"] > 0


# ------------------------------------------------------------------------------------------------ takeover
# UAV 0 gets targets 0 and 1, UAV 1 targets 2 and 3 (equal split); UAV 1 is removed at 25 s, before it reaches
# either of its targets (it leaves its pad at about 17 s; the nearest target is 186 m away)
TAKEOVER_TARGETS = [(100.0, 0.0), (150.0, 50.0), (-190.0, 0.0), (-200.0, 80.0)]
TAKEOVER_HOMES = [(4.0, 0.0), (-4.0, 0.0)]


def _takeover(channel):
    coop = CoopParams(comm_range=channel.range if channel is not None and channel.mode == "radio" else 1e9)
    return simulate_fleet(_params("C", TAKEOVER_TARGETS, TAKEOVER_HOMES), channel, coop, remove={1: 25.0},
                          t_end=900.0)


def test_a_lost_uavs_targets_are_taken_over_when_the_channel_told():
    res = _takeover(CH.ChannelParams(mode="perfect", n_uavs=2))
    s0, s1 = res.strategies
    assert s1.visited == []                              # removed before any photo
    assert sorted(s0.visited) == [0, 1, 2, 3]
    assert s0.coop.takeovers == 2
    assert s0.state == LANDED_BASE


def test_no_takeover_without_the_news():
    for channel in (None, CH.ChannelParams(mode="none", n_uavs=2),
                    CH.ChannelParams(loss=1.0, n_uavs=2),           # every message lost: never heard
                    # heard on the ground, then silent because it flew out of range (removed out of range too)
                    CH.ChannelParams(range=50.0, n_uavs=2)):
        res = _takeover(channel)
        s0 = res.strategies[0]
        assert sorted(s0.visited) == [0, 1], channel
        assert s0.coop.takeovers == 0


# ------------------------------------------------------------------------------------------------ head-on
HEAD_ON_TARGETS = [(260.0, 0.0), (-260.0, 0.0)]
HEAD_ON_HOMES = [(-200.0, 0.0), (200.0, 0.0)]


def test_head_on_course_b_collides_c_avoids():
    b = simulate_fleet(_params("B", HEAD_ON_TARGETS, HEAD_ON_HOMES), t_end=120.0)
    assert (0, 1) in b.first_contact                    # B: straight into each other (closing at 20 m/s)
    c = simulate_fleet(_params("C", HEAD_ON_TARGETS, HEAD_ON_HOMES),
                       CH.ChannelParams(range=300.0, period=1.0, latency=0.2, n_uavs=2), t_end=120.0)
    assert c.first_contact == {}
    assert c.closest[(0, 1)] > 2.6 + 1.0                 # clear by more than a metre
    s0, s1 = c.strategies
    assert s1.coop.give_ways >= 1 and s0.coop.give_ways == 0     # the higher index gives way
    assert [s.visited for s in c.strategies] == [[0], [1]]        # and both still photograph their target


def test_take_off_ring_departures_keep_apart_with_c():
    # four UAVs on the 8 m ring whose first targets lie across the ring: the paths out cross at the base
    targets = [(0.0, -150.0), (-150.0, 0.0), (0.0, 150.0), (150.0, 0.0)]
    params = [dataclasses.replace(p, assignment="equal") for p in _params("B", targets, RING)]
    b = simulate_fleet(params, t_end=90.0)
    c = simulate_fleet([dataclasses.replace(p, strategy="C") for p in params],
                       CH.ChannelParams(range=300.0, period=0.5, n_uavs=4), t_end=90.0)
    assert b.first_contact, "the crossing departures should collide under B"
    assert c.first_contact == {}


# ------------------------------------------------------------------------------------------------ rules one by one
def _message(sender, x, y, state=TRANSIT, target=-1, claims=(), visited=(), z=20.0, sent=0.0):
    return (x, y, z, 0.0, 0.0, x, y, sent, sender, state, target, *CH.encode_mask(claims), *CH.encode_mask(visited))


def _flying(index=0, targets=((100.0, 0.0), (0.0, 100.0), (-100.0, 0.0), (0.0, -100.0)), count=2):
    s = CooperativeStrategy(StrategyParams(strategy="C", uav_index=index, uav_count=count, targets=list(targets),
                                           cruise_altitude=20.0))
    s.step(0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1)          # airborne: starts its first leg
    return s


def test_visited_news_removes_a_target():
    s = _flying()
    assert s.state == TRANSIT and s.remaining == [0, 1]
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1, messages=[_message(1, 50.0, 50.0, visited=[0])])
    assert s.remaining == [1] and s.current_target == 1


def test_outbid_claim_is_dropped_and_a_worse_one_kept():
    s = _flying()
    # UAV 1 also claims target 1 (0, 100): from (0, 90) its bid 10 m beats ours (100 m); it claims 0 from far away
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1, messages=[_message(1, 0.0, 90.0, claims=[0, 1])])
    assert s.remaining == [0] and s.coop.drops == 1


def test_orphans_of_a_uav_gone_home_go_to_the_best_bidder():
    s = _flying(index=0, count=3)
    # UAV 1 returns on low battery and still claims 2 and 3; UAV 2 is active at (-90, 0), next to target 2
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1,
           messages=[_message(1, 10.0, 10.0, state=RETURN_LOW, claims=[2, 3]), _message(2, -90.0, 0.0, claims=[])])
    # equal split of 4 targets over 3 UAVs: ours 0 and 1.  Orphan 2 (-100, 0) is UAV 2's (10 m against our
    # 100 m), orphan 3 (0, -100) ours (100 m against 134.5 m)
    assert s.remaining == [0, 1, 3] and s.coop.takeovers == 1


def test_a_finished_uav_turns_back_for_an_orphan():
    s = _flying(targets=((5.0, 0.0), (500.0, 0.0)), count=2)       # target 0 is at the arrival radius: done
    s.step(0.5, 5.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1)
    assert s.state == RETURN_DONE and s.remaining == []
    s.step(1.0, 5.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1, messages=[_message(1, 300.0, 0.0, state=RETURN_LOW, claims=[1])])
    assert s.state == TRANSIT and s.current_target == 1


@pytest.mark.parametrize("loss", [0.0, 0.3])
def test_same_seed_same_flight(loss):
    ch = CH.ChannelParams(range=250.0, period=0.5, latency=0.3, loss=loss, n_uavs=4, seed=3)
    a = simulate_fleet(_params("C", SPREAD, RING), ch, t_end=150.0)
    b = simulate_fleet(_params("C", SPREAD, RING), dataclasses.replace(ch), t_end=150.0)
    assert _fingerprint(a) == _fingerprint(b) and a.channel.counters == b.channel.counters


def test_a_conflict_with_a_uav_that_falls_silent_ends():
    # UAV 1 (gives way to UAV 0) flies east; UAV 0, 30 m ahead, comes head-on at 10 m/s: conflict, UAV 1 holds and
    # climbs.  Then UAV 0 is never heard again (out of range): the conflict must end by itself (its extrapolated
    # path passes, or lost_timeout), not wait for a message that never comes.
    s = _flying(index=1, targets=((500.0, 0.0), (600.0, 0.0)), count=2)
    m0 = (30.0, 0.0, 20.0, -10.0, 0.0, -500.0, 0.0, 1.0, 0, TRANSIT, -1, *CH.encode_mask([]), *CH.encode_mask([]))
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1, messages=[m0])
    assert s.coop.conflicts and s.coop.holding and s.sp[2] == 25.0 and s.sp[:2] == (0.0, 0.0)
    t = 1.0
    while t < 1.0 + s.c.lost_timeout + 0.05:
        t = round(t + 0.1, 9)
        s.step(t, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1)
    assert not s.coop.conflicts and not s.coop.holding and s.coop.layer == 0
    assert s.sp == (600.0, 0.0, 20.0)                  # back at cruise, on to its target (index 1)
