"""SITL's JSON-backend packets: the servo packet codec against hand-packed bytes, the answer's text, and the
timestamps that keep the firmware's microsecond clock on the physics clock."""
import json

import pytest

from sitlsim import physics as ph
from sitlsim.frames import FrameError, answer, decode_servo, encode_servo, fixed, seconds


def test_servo_packet_decodes_hand_packed_bytes():
    # magic 18458 = 0x481A, frame_rate 1200 = 0x04B0, frame_count 0x01020304, pwm 1000 = 0x03E8 ...
    data = (b"\x1a\x48" + b"\xb0\x04" + b"\x04\x03\x02\x01" + b"\xe8\x03" + b"\xd0\x07" + b"\xdc\x05"
            + b"\x00\x00" + b"\x01\x00" * 12)
    f = decode_servo(data)
    assert (f.magic, f.frame_rate, f.frame_count) == (18458, 1200, 0x01020304)
    assert f.pwm == (1000, 2000, 1500, 0) + (1,) * 12
    assert encode_servo(1200, 0x01020304, f.pwm) == data


def test_servo_packet_with_32_channels():
    # magic 29569 = 0x7381
    data = b"\x81\x73" + b"\x90\x01" + b"\x07\x00\x00\x00" + b"".join(bytes([i, 0x04]) for i in range(32))
    f = decode_servo(data)
    assert (f.magic, f.frame_rate, f.frame_count) == (29569, 400, 7)
    assert f.pwm == tuple(0x0400 + i for i in range(32))
    assert encode_servo(400, 7, f.pwm) == data


@pytest.mark.parametrize("data, why", [
    (b"\x1a\x48\xb0", "shorter than its 8-byte header"),
    (b"\x00\x00" + bytes(38), "magic 0"),
    (b"\x1a\x48" + bytes(40), "has 42 bytes, expected 40"),
    (b"\x81\x73" + bytes(38), "has 40 bytes, expected 72"),
])
def test_bad_servo_packets_are_refused(data, why):
    with pytest.raises(FrameError, match=why):
        decode_servo(data)


def test_answer_text_is_what_sitls_parser_reads():
    text = answer(500_000_001, (0.0, -0.25, 1.0), (0.0, 0.0, -9.80665), (1.0, 2.0, -3.0), (0.5, 0.0, 0.0),
                  (1.0, 0.0, 0.0, 0.0))
    assert text == (b'\n{"timestamp":0.500000001,"imu":{"gyro":[0.000000000,-0.250000000,1.000000000],'
                    b'"accel_body":[0.000000000,0.000000000,-9.806650000]},'
                    b'"position":[1.000000000,2.000000000,-3.000000000],"velocity":[0.500000000,0.000000000,'
                    b'0.000000000],"quaternion":[1.000000000,0.000000000,0.000000000,0.000000000],'
                    b'"no_time_sync":1}\n')
    assert b": " not in text and text.startswith(b"\n") and text.endswith(b"\n")
    assert b"no_time_sync" not in answer(0, (0,) * 3, (0,) * 3, (0,) * 3, (0,) * 3, (1, 0, 0, 0), False)
    d = json.loads(text)
    assert set(d) == {"timestamp", "imu", "position", "velocity", "quaternion", "no_time_sync"}


@pytest.mark.parametrize("v, text", [
    (0.0, "0.000000000"), (-0.0, "0.000000000"), (-1e-12, "0.000000000"), (1e-9, "0.000000001"),
    (-2.5e-9, "-0.000000002"), (3.5e-9, "0.000000004"),     # half to even, on the product v * 1e9
    (-1234.5678901234, "-1234.567890123"), (float("nan"), "0.000000000"),
    (1e300, "9000000000.000000000"), (-float("inf"), "-9000000000.000000000")])
def test_fixed_point_numbers(v, text):
    assert fixed(v) == text


def test_seconds_are_exact():
    assert seconds(0) == "0.000000000" and seconds(123_456_789_012) == "123.456789012"


def firmware_clock_us(texts, start_us=0):
    """SITL's clock as SIM_JSON.cpp keeps it: time_now_us (uint64) += (t_k - t_k-1) * 1e6, truncated, with
    t_k = atof(text) (Python's float() rounds decimal strings correctly, as glibc's strtod)."""
    u, stamps = start_us, [float(t) for t in texts]
    for a, b in zip(stamps, stamps[1:]):
        u = int(u + (b - a) * 1.0e6)
    return u


@pytest.mark.parametrize("k0", [0, 3_600 * 1200, 24 * 3_600 * 1200])     # start, 1 h, 24 h
def test_timestamps_keep_the_firmware_clock_on_the_physics_clock(k0):
    n = 24_000                                                              # 20 s of frames
    texts = [seconds(ph.timestamp_ns(k, 1200)) for k in range(k0, k0 + n + 1)]
    u0 = k0 * 1_000_000 // 1200
    # the firmware's microseconds = floor(physics time in us) after every frame
    u = u0
    for k in range(1, n + 1):
        u = int(u + (float(texts[k]) - float(texts[k - 1])) * 1.0e6)
        if k % 97 == 0 or k == n:
            assert u == (k0 + k) * 1_000_000 // 1200
    # what plain timestamps k/1200 would do: 1/1200 s truncates to 833 us, the clock loses 0.4 ms/s
    plain = [repr(k / 1200) for k in range(k0, k0 + n + 1)]
    lost = (k0 + n) * 1_000_000 // 1200 - firmware_clock_us(plain, u0)
    assert lost > 7000


def test_timestamps_of_other_frame_rates():
    for rate in (400, 1000, 1200, 2000, 7):
        texts = [seconds(ph.timestamp_ns(k, rate)) for k in range(0, 5 * rate + 1)]
        assert firmware_clock_us(texts) == 5_000_000
        assert ph.timestamp_ns(5 * rate, rate) == 5_000_000_000 + 5 * rate
