"""A communication step far shorter than the models' internal sub-step is one sub-step, not a division by zero.

OMSimulator's clock is a sum (t_{n+1} = t_n + h), so a run to 10 s at h = 0.1 ends with t = 9.99999999999998
and one more doStep of 1.95e-14 s up to the stop time.  The dynamics and the battery split a step into
round(dt / 0.01) sub-steps, corrected upward when that does not fit; for such a step the correction gave 0
sub-steps and dt / 0 (measured: UavDynamics's doStep raised ZeroDivisionError, and OMSimulator aborted in
its logger).
"""
import pytest

from uavsim.battery import Battery
from uavsim.dynamics import FLY, Dynamics

TINY = 10.0 - 9.99999999999998          # OMSimulator's last step of a 10 s run at 0.1 s


def test_dynamics_takes_a_tiny_step_as_one_substep():
    d = Dynamics()
    while d.phase != FLY:
        d.step(0.1, 1)
    d.step(1.0, 2, (30.0, 0.0, 20.0))                        # under way east
    assert d._count_substeps(TINY) == (1, TINY)
    x, vx = d.pos[0], d.vel[0]
    d.step(TINY, 2, (30.0, 0.0, 20.0))
    # the vehicle moves by about vx * dt in that time, no more
    assert d.pos[0] - x == pytest.approx(vx * TINY, rel=1e-3, abs=1e-15)


def test_battery_takes_a_tiny_step_as_one_substep():
    b = Battery()
    assert b._substeps(TINY) == (1, TINY)
    b.step(1.0, 0.0, 0.0, 1)
    used = b.energy_used
    b.step(TINY, 0.0, 0.0, 1)
    # hover power (about 200 W) for 2e-14 s: the energy grows by power * dt
    assert b.energy_used - used == pytest.approx(b.power * TINY, rel=1e-2)


@pytest.mark.parametrize("dt, dynamics, battery", [(0.1, 10, 2), (0.05, 5, 1), (1.0, 100, 20), (0.013, 2, 1)])
def test_ordinary_steps_keep_their_subdivision(dt, dynamics, battery):
    """The fix changes only steps that got no sub-step: 0.1 s is still 10 dynamics sub-steps of 0.01 s and two
    battery sub-steps of 0.05 s; 0.013 s, which neither divides, is rounded up (2 and 1)."""
    assert Dynamics()._count_substeps(dt)[0] == dynamics
    assert Battery()._substeps(dt)[0] == battery
