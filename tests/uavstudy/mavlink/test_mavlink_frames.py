"""uavstudy.mavlink.frames packs the bytes pymavlink packs (the reference encoder), sequence numbers included."""
import pytest
from pymavlink.dialects.v20 import common as m

from uavstudy.mavlink.frames import Frame

CASES = [
    (m.MAVLink_global_position_int_message, (123400, -72750000, -359650000, 540123, 20000, -150, 320, 0, 9000)),
    (m.MAVLink_global_position_int_message, (5, 1, 2, 3, 4, 5, 6, 7, 0)),          # trailing zeros cut
    (m.MAVLink_attitude_message, (100, 0.0, -0.21, 2.5, 0.0, 0.0, 0.0)),
    (m.MAVLink_heartbeat_message, (2, 0, 129, 9, 4, 3)),
    (m.MAVLink_battery_status_message, (0, 1, 1, 32767, [11800] + [65535] * 9, 1234, 2100, 5400, 64)),
    (m.MAVLink_sys_status_message, (0, 0, 0, 0, 11800, 1234, 64, 0, 0, 0, 0, 0, 0)),
    (m.MAVLink_mission_current_message, (3, 8)),
    (m.MAVLink_extended_sys_state_message, (0, 2)),
    (m.MAVLink_heartbeat_message, (0, 0, 0, 0, 0, 0)),                              # all zero: one byte kept
]


@pytest.mark.parametrize("cls, values", CASES)
def test_frame_equals_pymavlink(cls, values):
    ours = m.MAVLink(None, srcSystem=17, srcComponent=1)
    ref = m.MAVLink(None, srcSystem=17, srcComponent=1)
    ours.seq = ref.seq = 254                        # the wrap of the sequence number too
    encode = getattr(ref, cls.msgname.lower() + "_encode")
    for _ in range(3):
        assert Frame(cls).pack(ours, *values) == encode(*values).pack(ref)
        ref.seq = (ref.seq + 1) % 256               # as pymavlink's MAVLink.send counts
    assert ours.seq == ref.seq == 1
    # and pymavlink reads it back
    parsed = m.MAVLink(None).parse_buffer(Frame(cls).pack(ours, *values))
    assert len(parsed) == 1 and parsed[0].get_type() == cls.msgname
