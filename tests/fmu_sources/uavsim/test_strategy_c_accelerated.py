"""Strategy C on the FMU shell's step (uavsim/cooperative_fmi.py) flies the same with the compiled B step
(uavsim/_strategy_ext.c, used on C's quiet steps) as without it, bit for bit: an accelerator equals its reference.

Each fleet flies the plain closed loop (uavsim/fleet_sim.py) with every C strategy stepped the way the UavStrategy
shell steps it, once with the compiled step and once without (as under COSIM_MASTER_PURE_PYTHON=1).  The flights
are chosen to pass through C's avoidance between messages (a broadcast every 0.5 s, 5 steps): the take-off ring
whose paths out cross, and a head-on pair, where a UAV sees another coming (``imminent``) before it gives way."""
from __future__ import annotations

import copy
import dataclasses

import pytest
from uavsim import channel as CH
from uavsim import cooperative_fmi, fleet_sim
from uavsim.cooperative import CooperativeStrategy
from uavsim.strategy import OUTPUT_NAMES, StrategyParams
from uavsim.strategy_accel import PAPER_ZONES, STRATEGY_STEP

STEP = 0.1
RING = [(0.0, 5.657), (5.657, 0.0), (0.0, -5.657), (-5.657, 0.0)]
_SENDER = cooperative_fmi.SLOT_FIELDS.index("sender")


@pytest.fixture(scope="module")
def ext():
    impl, why = STRATEGY_STEP.load()
    if impl is None:
        pytest.skip(f"the compiled strategy step is not available here: {why}")
    return impl


class _Shell:
    """The UavStrategy shell's variables (only what cooperative_fmi.step reads and writes)."""

    def __init__(self, model):
        self._model = model
        cooperative_fmi.register(self)
        self._publish()

    def _declare(self, *args):
        pass

    par_real = in_real = in_int = out_real = out_int = par_bool = _declare

    def _publish(self):
        self.__dict__.update(zip(OUTPUT_NAMES, self._model.outputs()))


def _state(strategy) -> str:
    """Everything a C strategy and its shell hold, as text (floats by repr: every bit)."""
    c = strategy.coop
    coop = {n: getattr(c, n) for n in c.__slots__ if n != "neighbours"}
    coop["neighbours"] = {j: [getattr(nb, n) for n in nb.__slots__] for j, nb in c.neighbours.items()}
    shell = {k: v for k, v in strategy.shell.__dict__.items() if k != "_model"}
    return repr((strategy.mission, coop, shell))


def _through_shell(fast_step, checked=None):
    """A C strategy class stepped the shell's way with ``fast_step``; with ``checked`` (a list), every step is
    also taken on a copy without it, and the steps whose results differ are appended (time, UAV index)."""
    class ThroughShell(CooperativeStrategy):
        """A C strategy that fleet_sim steps through the shell's step, as the FMU does."""

        def __init__(self, params, coop=None):
            super().__init__(params, coop)
            self.shell = _Shell(self)
            self._in_shell = False

        def step(self, t, x, y, z, vx, vy, phase, consumed, command=None, messages=()):
            if self._in_shell:                      # the shell's call of the Python step
                return super().step(t, x, y, z, vx, vy, phase, consumed, command, messages)
            d = self.shell.__dict__
            d.update(x=float(x), y=float(y), z=float(z), vx=float(vx), vy=float(vy), phase=int(phase),
                     consumed=float(consumed), command=0)
            # the channel FMU fills the slots in order, the rest empty
            for s, slot in enumerate(cooperative_fmi.SLOTS):
                if s < len(messages):
                    d.update(zip(slot, messages[s]))
                else:
                    d[slot[_SENDER]] = CH.EMPTY
            reference = copy.deepcopy(self) if checked is not None else None
            self._shell_step(t, fast_step)
            if reference is not None:
                reference._shell_step(t, None)
                if _state(reference) != _state(self):
                    checked.append((t, int(self.p.uav_index)))

        def _shell_step(self, t, fast):
            self._in_shell = True
            try:
                cooperative_fmi.step(self.shell, self, t, STEP, fast)
            finally:
                self._in_shell = False

    return ThroughShell


def _fly(monkeypatch, fast_step, params, channel, t_end, checked=None):
    monkeypatch.setattr(fleet_sim, "CooperativeStrategy", _through_shell(fast_step, checked))
    res = fleet_sim.simulate_fleet(params, channel, step=STEP, t_end=t_end)
    return [(tuple(d.pos), tuple(d.vel), s.outputs(), list(s.visited), list(s.mission.remaining), s.sp,
             s.coop.layer, s.coop.holding, s.coop.conflicts, s.coop.imminent, s.coop.give_ways, s.coop.takeovers,
             s.coop.drops, {k: v for k, v in s.shell.__dict__.items() if not k.startswith("_")})
            for d, s in zip(res.dynamics, res.strategies)], res.closest


def _params(targets, homes, **kw):
    return [StrategyParams(strategy="C", uav_index=i, uav_count=len(homes), targets=targets, home_x=h[0],
                           home_y=h[1], cruise_altitude=20.0, **kw) for i, h in enumerate(homes)]


FLIGHTS = {
    # four UAVs on the 8 m ring whose first targets lie across it: the paths out cross at the base
    "ring": (_params([(0.0, -150.0), (-150.0, 0.0), (0.0, 150.0), (150.0, 0.0)], RING, assignment="equal"),
             CH.ChannelParams(range=300.0, period=0.5, n_uavs=4), 60.0),
    # two UAVs flying at each other from 200 m apart, heard with latency
    "head-on": (_params([(-100.0, 0.0), (100.0, 0.0)], [(100.0, 0.0), (-100.0, 0.0)], assignment="equal"),
                CH.ChannelParams(range=300.0, period=0.5, latency=0.2, n_uavs=2), 60.0),
    # five UAVs in a row among the paper's zones, their paths out fanning across each other (a UAV sees a
    # higher index coming with no message in between: the case found in ssp/coop_zones_4uav_C.ssp)
    "row in zones": (_params([(199.0, 286.0), (78.0, 117.0), (-29.0, 14.0), (-282.0, 105.0), (182.0, 96.0),
                              (-44.0, 142.0), (-225.0, -173.0), (-272.0, -258.0), (-254.0, 250.0)],
                             [(-12.0, 0.0), (-4.0, 0.0), (4.0, 0.0), (12.0, 4.0), (20.0, 4.0)], zones=PAPER_ZONES,
                             zone_planning=False),
                     CH.ChannelParams(range=300.0, period=1.0, n_uavs=5), 30.0),
    # five UAVs in a row, no zones, a lossy short-range channel
    "lossy row": (_params([(-60.0, -3.0), (-73.0, -199.0), (-161.0, 192.0), (-22.0, 48.0), (-173.0, 129.0),
                           (-102.0, 56.0)], [(-12.0, 4.0), (-4.0, 4.0), (4.0, 0.0), (12.0, 0.0), (20.0, 0.0)]),
                  CH.ChannelParams(range=50.0, period=0.5, loss=0.3, n_uavs=5), 60.0),
}


@pytest.fixture(scope="module")
def flown(ext):
    """Each flight with the compiled step, every step also taken on a copy without it (checking a step leaves the
    flight itself as it is: the copy is stepped, not the UAV), flown once for both tests below: name -> (final
    states, closest approach, steps the compiled step took, the steps that differed)."""
    done = {}

    def fly(name):
        if name not in done:
            params, channel, t_end = FLIGHTS[name]
            differ = []
            ext.reset_stats()
            with pytest.MonkeyPatch.context() as mp:
                fast, closest = _fly(mp, ext.step, params, dataclasses.replace(channel), t_end, checked=differ)
            done[name] = fast, closest, ext.stats()["handled"], differ
        return done[name]
    return fly


@pytest.mark.parametrize("name", sorted(FLIGHTS))
def test_c_flies_the_same_with_and_without_the_compiled_step(ext, flown, monkeypatch, name):
    params, channel, t_end = FLIGHTS[name]
    fast, closest, handled, _ = flown(name)
    plain, plain_closest = _fly(monkeypatch, None, params, dataclasses.replace(channel), t_end)
    assert handled > 0, "the compiled step took no step: the comparison would be empty"
    assert any(s[10] for s in plain), "no UAV gave way: the flight does not pass through C's avoidance"
    for k, (a, b) in enumerate(zip(fast, plain)):
        assert repr(a) == repr(b), f"{name}: UAV {k} differs with the compiled step"
    assert repr(closest) == repr(plain_closest)


@pytest.mark.parametrize("name", sorted(FLIGHTS))
def test_every_step_with_the_compiled_step_equals_the_python_step(flown, name):
    # step by step: also what leaves no trace in the final state (a pass watched without a hold, then dropped)
    differ = flown(name)[3]
    assert differ == [], f"{name}: the shell's step with the compiled step differs at (t, UAV) {differ[:5]}"
