"""The ground station's MAVLink conversation (sitlsim/mavlink_link.py) against a fake ArduCopter on loopback TCP.

Expectations come from the script of the fake peer (tests/sitlveh_helpers.py): when it becomes ready, how
many arm commands it refuses, when it goes silent; and from the MAVLink common message set (interval in us =
1e6 / rate, lat/lon in 1e-7 deg, GUIDED = 4 and LAND = 9 in ArduCopter's mode numbering).
"""
from __future__ import annotations

import pytest
from sitlveh_helpers import FakeCopter, mav, read_all, tcp_pair

from sitlsim.mavlink_link import POSITION_ONLY, STREAMS, GroundStation, LinkError

DT = 0.05


class Loop:
    """Ground station and fake copter in lock-step on the test's clock."""

    def __init__(self, **fake):
        self.gcs_sock, self.veh_sock = tcp_pair()
        self.gs = GroundStation(arm_retry=1.0, arm_timeout=6.0, heartbeat_timeout=3.0, goto_repeat=1.0)
        self.fake = FakeCopter(self.veh_sock, **fake)
        self.now = 0.0

    def tick(self):
        out = self.gs.update(self.now)
        if out:
            self.gcs_sock.sendall(out)
        self.fake.step(self.now)
        self.gs.feed(read_all(self.gcs_sock))
        self.now = round(self.now + DT, 9)

    def run_until(self, cond, limit):
        while not cond():
            if self.now > limit:
                raise AssertionError(f"not reached by t={limit}: stage {self.gs.stage}")
            self.tick()
        return self.now

    def close(self):
        self.gcs_sock.close()
        self.veh_sock.close()


@pytest.fixture
def loop_factory():
    made = []

    def make(**kw):
        lp = Loop(**kw)
        made.append(lp)
        return lp
    yield make
    for lp in made:
        lp.close()


def test_gets_ready_only_once_the_position_estimate_is_there(loop_factory):
    lp = loop_factory(ready_at=20.0)
    t = lp.run_until(lambda: lp.gs.ready, 40.0)
    # ready in the first exchange after the fake's EKF, GPS, home and pre-arm turn good at 20 s
    assert 20.0 <= t <= 20.0 + 3 * DT
    assert lp.fake.got_gcs_packet
    assert set(lp.fake.intervals) == set(STREAMS)
    for mid, rate in STREAMS.items():
        assert lp.fake.intervals[mid] == pytest.approx(1e6 / rate)
    assert lp.fake.arm_attempts == []        # nothing armed while getting ready


def test_refused_arming_is_retried_then_takeoff_follows(loop_factory):
    lp = loop_factory(ready_at=1.0, refusals=2)
    lp.run_until(lambda: lp.gs.ready, 5.0)
    t_req = lp.now
    lp.gs.takeoff(12.5)
    lp.run_until(lambda: lp.gs.stage == "flying", t_req + 10.0)
    attempts = lp.fake.arm_attempts
    assert len(attempts) == 3
    # one retry per arm_retry (1 s) of vehicle time
    assert attempts[1] - attempts[0] == pytest.approx(1.0, abs=DT + 1e-9)
    assert attempts[2] - attempts[1] == pytest.approx(1.0, abs=DT + 1e-9)
    assert lp.fake.mode == 4 and lp.fake.armed and lp.fake.in_air
    takeoffs = [c for c in lp.fake.commands if c[1] == mav.MAV_CMD_NAV_TAKEOFF]
    assert takeoffs and takeoffs[0][2][6] == pytest.approx(12.5)
    assert takeoffs[0][0] >= attempts[2]     # the takeoff only after the accepted arm
    assert lp.gs.last_reason() == "PreArm: Need Position Estimate"


def test_arming_refused_too_long_is_an_error_quoting_the_reason(loop_factory):
    lp = loop_factory(ready_at=1.0, refusals=-1)
    lp.run_until(lambda: lp.gs.ready, 5.0)
    lp.gs.takeoff(10.0)
    t_req = lp.now
    with pytest.raises(LinkError, match="arming refused .*Need Position Estimate") as err:
        lp.run_until(lambda: False, t_req + 20.0)
    assert "\n" not in str(err.value)
    # arm_timeout is 6 s of vehicle time after the first attempt (plus the GUIDED exchange)
    assert t_req + 6.0 <= lp.now <= t_req + 6.0 + 1.0


def test_lost_heartbeat_is_an_error_after_the_timeout(loop_factory):
    lp = loop_factory(ready_at=1.0, silent_from=10.0)
    with pytest.raises(LinkError, match="no HEARTBEAT for"):
        lp.run_until(lambda: False, 30.0)
    # last heartbeat at 9 s (1 Hz from 0), timeout 3 s: the error comes just after 12 s
    assert 12.0 < lp.now <= 12.0 + 3 * DT


def test_no_heartbeat_at_all_is_an_error(loop_factory):
    lp = loop_factory(silent_from=0.0)
    with pytest.raises(LinkError, match="no HEARTBEAT from the vehicle"):
        lp.run_until(lambda: False, 30.0)
    assert 3.0 < lp.now <= 3.0 + 3 * DT


def test_goto_sends_position_targets_and_land_ends_disarmed(loop_factory):
    lp = loop_factory(ready_at=1.0, land_time=2.0)
    lp.run_until(lambda: lp.gs.ready, 5.0)
    lp.gs.takeoff(10.0)
    lp.run_until(lambda: lp.gs.stage == "flying", 10.0)
    lp.gs.goto(-7.2760001, -35.9640002, 20.0)
    t0 = lp.now
    lp.run_until(lambda: lp.now > t0 + 2.5, 20.0)
    sent = lp.fake.targets
    # once on change, then again every goto_repeat (1 s): 3 in 2.5 s
    assert len(sent) == 3
    m = sent[0][1]
    assert (m.lat_int, m.lon_int, m.alt) == (-72760001, -359640002, 20.0)
    assert m.coordinate_frame == mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT and m.type_mask == POSITION_ONLY
    lp.gs.land()
    t_land = lp.now
    lp.run_until(lambda: lp.gs.stage == "landed", t_land + 10.0)
    assert lp.fake.mode == 9
    assert lp.now >= t_land + 2.0            # the fake touches down 2 s after LAND
    assert not lp.gs.armed


def test_a_position_target_goes_out_once_per_change_by_default(loop_factory):
    """A careful ground station does not repeat a GUIDED position target over TCP: the firmware keeps it (no
    timeout for position targets) and plans its path from its current state when one arrives."""
    lp = loop_factory(ready_at=1.0)
    lp.gs.goto_repeat = None                 # the default of GroundStation (the Loop sets 1 s)
    assert GroundStation().goto_repeat is None
    lp.run_until(lambda: lp.gs.ready, 5.0)
    lp.gs.takeoff(10.0)
    lp.run_until(lambda: lp.gs.stage == "flying", 10.0)
    for k, target in enumerate([(-7.2760001, -35.9640002, 20.0), (-7.2770001, -35.9640002, 20.0)]):
        lp.gs.goto(*target)
        t0 = lp.now
        lp.run_until(lambda: lp.now > t0 + 3.0, 30.0)
        lp.gs.goto(*target)                  # the same set-point again: nothing new to say
        lp.run_until(lambda: lp.now > t0 + 4.0, 30.0)
        assert len(lp.fake.targets) == k + 1
        assert lp.fake.targets[-1][1].lat_int == round(target[0] * 1e7)
