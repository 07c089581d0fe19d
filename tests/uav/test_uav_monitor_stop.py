"""endWhenAllLanded: the UAV monitor asks the master to stop at the same step whether its common step runs in C
or in Python.  The C path's steps skip the fleet-done check (they change no phase, removal or mission state, so
the check could only repeat the last Python step's answer); fleets landing one by one, with the strategy
registering a landing a few steps late, and with a UAV that never takes off, show that this loses no stop."""
import numpy as np
import pytest

from test_uav_monitor import FakeCtx, annotation
from uavstudy import monitor_native
from uavstudy.monitor import UavMonitor
from uavstudy.names import AIRBORNE_PHASES, FINAL_STATES, PHASE_LANDED, PHASE_PREFLIGHT

FLY = AIRBORNE_PHASES[1]
NAMES = [f"u{k}" for k in range(4)]
STEPS = 80

if monitor_native.step_function()[0] is None:
    pytest.skip(f"no C step: {monitor_native.step_function()[1]}", allow_module_level=True)


def fleet(seed):
    """load(ctx, s) of 4 UAVs flying far apart that land one by one (or one never takes off)."""
    rng = np.random.default_rng(seed)
    land = rng.integers(10, STEPS + 10, len(NAMES))          # some land after the run's end
    registered = land + rng.choice([0, 1, 3], len(NAMES))   # the strategy's landed_base comes with or after it
    grounded = rng.integers(len(NAMES)) if rng.random() < 0.2 else -1
    speed = rng.uniform(1.0, 8.0, len(NAMES))

    def load(ctx, s):
        for k, name in enumerate(NAMES):
            y = speed[k] * min(s, land[k])
            if k == grounded:
                phase, z = PHASE_PREFLIGHT, 0.0
            elif s >= land[k]:
                phase, z = PHASE_LANDED, 0.0
            else:
                phase, z = FLY, 20.0
            ctx.set(name, x=300.0 * k, y=y, z=z, phase=phase,
                    mission_state=FINAL_STATES[0] if s >= registered[k] and k != grounded else 2)
    return load


def first_stop(seed, native):
    mon = UavMonitor(annotation(NAMES, extra='endWhenAllLanded="true"'), None, "stop.ssp")
    mon.native = native
    ctx = FakeCtx(NAMES)
    load = fleet(seed)
    load(ctx, 0)
    mon.attach(ctx, 0.0)
    assert (mon._native is not None) == native
    codes = []
    if native:
        step = mon._native.step

        def counted(t0, t1):
            codes.append(step(t0, t1))
            return codes[-1]
        mon._native.step = counted
    for s in range(1, STEPS + 1):
        load(ctx, s)
        mon.after_step(s - 1, 0.5 * (s - 1), 0.5 * s)
        if ctx.stop_reasons:
            return s, codes
    return None, codes


def test_the_run_stops_at_the_same_step_with_the_c_step():
    stops = done = 0
    for seed in range(60):
        want, _ = first_stop(seed, native=False)
        got, codes = first_stop(seed, native=True)
        assert got == want, seed
        stops += want is not None
        done += codes.count(monitor_native.MS_DONE)
    # not vacuous: many runs stop, many do not, and C did the steps in between
    assert 15 < stops < 55 and done > 1000, (stops, done)
