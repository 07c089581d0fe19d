"""Strategy C's event outputs (uavsim/cooperative.py ``last_taken``/``last_dropped``/``giving_way_to``, published by
uavsim/cooperative_fmi.py as ``taken0/1``, ``taken_from``, ``dropped0/1``, ``dropped_to``, ``give_way_to``), on
hand-made messages whose outcome follows from the allocation rules and the closest-approach geometry by hand."""
from build_script import load_shell

from uavsim import channel as CH
from uavsim.cooperative import CooperativeStrategy
from uavsim.strategy import RETURN_LOW, TRANSIT, StrategyParams

TARGETS = [(100.0, 0.0), (0.0, 100.0), (-100.0, 0.0), (0.0, -100.0)]


def _message(sender, x, y, state=TRANSIT, claims=(), vx=0.0, vy=0.0, wx=None, wy=None, z=20.0, sent=0.0):
    return (x, y, z, vx, vy, x if wx is None else wx, y if wy is None else wy, sent, sender, state, -1,
            *CH.encode_mask(claims), *CH.encode_mask(()))


def _flying(index=0, count=3, targets=TARGETS):
    s = CooperativeStrategy(StrategyParams(strategy="C", uav_index=index, uav_count=count, targets=list(targets),
                                           cruise_altitude=20.0))
    s.step(0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1)          # airborne: starts its first leg
    return s


def test_drops_name_each_target_and_its_best_bidder():
    # 4 targets over 2 UAVs: ours are 0 (100, 0) and 1 (0, 100), bids 100 m each.  UAV 1 at (0, 90) claims 1 (bid
    # 10 m), UAV 2 at (95, 0) claims 0 (bid 5 m) and 1 (bid 134.6 m, worse than UAV 1's)
    s = _flying(count=2)
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1,
           messages=[_message(1, 0.0, 90.0, claims=[1]), _message(2, 95.0, 0.0, claims=[0, 1])])
    assert s.remaining == [] and s.coop.drops == 2
    assert s.coop.last_dropped == [(0, 2), (1, 1)]


def test_takeovers_name_the_gone_claimant():
    s = _flying(count=3)
    # UAV 1 goes home on low battery claiming 2 and 3; UAV 2 at (-90, 0) is next to 2: ours is 3 (100 m < 134.5 m)
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1,
           messages=[_message(1, 10.0, 10.0, state=RETURN_LOW, claims=[2, 3]), _message(2, -90.0, 0.0)])
    assert s.coop.last_taken == [(3, 1)] and s.coop.takeovers == 1
    assert s.coop.last_dropped == []


def test_give_way_names_the_lower_index_head_on():
    # we are UAV 1 at (0, 0) flying east to target 0 (100, 0); UAV 0 comes west from (60, 0) at 10 m/s: the
    # closest approach is a 0 m miss (< 6 m separation) within the 10 s horizon: the higher index gives way to 0
    s = _flying(index=1, count=2, targets=[(-100.0, 0.0), (100.0, 0.0)])
    assert s.giving_way_to() == -1
    s.step(1.0, 0.0, 0.0, 20.0, 0.0, 0.0, 2, 0.1,
           messages=[_message(0, 60.0, 0.0, vx=-10.0, wx=-100.0, wy=0.0, sent=1.0)])
    assert s.giving_way_to() == 0 and s.coop.give_ways == 1
    # UAV 0 has passed and flies away west 100 m behind us: no conflict left
    s.step(2.0, 0.0, 0.0, 25.0, 0.0, 0.0, 2, 0.1,
           messages=[_message(0, -100.0, 0.0, vx=-10.0, wx=-200.0, wy=0.0, sent=2.0)])
    assert s.giving_way_to() == -1


def test_the_fmu_shell_publishes_them():
    shell = load_shell("UavStrategy")
    shell.strategy, shell.uav_count, shell.targets = "C", 2, ";".join(f"{x},{y}" for x, y in TARGETS)
    shell.exit_initialization_mode()
    shell.z, shell.phase, shell.consumed = 20.0, 2, 0.1
    assert (shell.taken_from, shell.dropped_to, shell.give_way_to) == (-1, -1, -1)
    shell.do_step(0.0, 0.1)
    message = _message(1, 0.0, 90.0, claims=[1])
    for name, value in zip(CH.MESSAGE_REAL + CH.MESSAGE_INT, message):
        setattr(shell, f"m1_{name}", value)
    shell.do_step(0.1, 0.1)
    assert shell.drops == 1
    assert (shell.dropped0, shell.dropped1, shell.dropped_to) == (*CH.encode_mask([1]), 1)
    assert (shell.taken0, shell.taken1, shell.taken_from) == (0, 0, -1)
