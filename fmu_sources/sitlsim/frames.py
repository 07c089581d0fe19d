"""The two packets of SITL's JSON physics protocol (../shared/sitl/README.md; ArduPilot
libraries/SITL/examples/JSON/readme.md).

SITL -> physics, one UDP datagram per physics step, little-endian::

    uint16 magic (18458; 29569 with SERVO_32_ENABLE), uint16 frame_rate, uint32 frame_count, uint16 pwm[16|32]

physics -> SITL: one JSON object framed by newlines.  SITL's parser is a string search, not a JSON parser:
it takes the text between the last two newlines it holds, finds ``"key":`` and reads the number right after
the colon, so there must be no space after a colon, and the object is both preceded and followed by "\\n"
(the leading one makes every datagram a complete line even for SITL's very first read).

``answer(...)`` formats the numbers with C's ``%.17g`` (timestamp, position: SITL reads them as double) and
``%.9g`` (the rest: read as float); Python's %-formatting and C's printf both round correctly, so the Python
and the compiled twin (physics.c: sitl_format) produce the same bytes (tested).
"""
from __future__ import annotations

import struct
from typing import NamedTuple

MAGIC_16 = 18458
MAGIC_32 = 29569
_HEAD = struct.Struct("<HHI")
_PWM16 = struct.Struct("<16H")
_PWM32 = struct.Struct("<32H")
SIZE_16 = _HEAD.size + _PWM16.size       # 40 bytes
SIZE_32 = _HEAD.size + _PWM32.size       # 72 bytes


class ServoFrame(NamedTuple):
    magic: int
    frame_rate: int
    frame_count: int
    pwm: tuple


class FrameError(ValueError):
    """A datagram that is not a SITL servo packet."""


def decode_servo(data: bytes) -> ServoFrame:
    """The servo packet in ``data``; FrameError when the size or magic is not SITL's."""
    if len(data) < _HEAD.size:
        raise FrameError(f"servo packet of {len(data)} bytes, shorter than its {_HEAD.size}-byte header")
    magic, rate, count = _HEAD.unpack_from(data)
    if magic == MAGIC_16:
        body, size = _PWM16, SIZE_16
    elif magic == MAGIC_32:
        body, size = _PWM32, SIZE_32
    else:
        raise FrameError(f"servo packet magic {magic}, expected {MAGIC_16} or {MAGIC_32}")
    if len(data) != size:
        raise FrameError(f"servo packet with magic {magic} has {len(data)} bytes, expected {size}")
    return ServoFrame(magic, rate, count, body.unpack_from(data, _HEAD.size))


def encode_servo(frame_rate: int, frame_count: int, pwm) -> bytes:
    """SITL's servo packet (16 or 32 channels by the length of ``pwm``): for tests and fake peers."""
    pwm = tuple(int(v) for v in pwm)
    if len(pwm) == 16:
        return _HEAD.pack(MAGIC_16, frame_rate, frame_count) + _PWM16.pack(*pwm)
    if len(pwm) == 32:
        return _HEAD.pack(MAGIC_32, frame_rate, frame_count) + _PWM32.pack(*pwm)
    raise ValueError(f"a servo packet carries 16 or 32 channels, not {len(pwm)}")


def _vec(values, fmt: str) -> str:
    return "[" + ",".join(fmt % v for v in values) + "]"


def answer(timestamp: float, gyro, accel_body, position, velocity, quaternion, no_time_sync: bool = True) -> bytes:
    """The physics' answer: newline-framed JSON, quaternion (w, x, y, z) body-to-NED attitude."""
    d, f = "%.17g", "%.9g"
    text = ('\n{"timestamp":' + d % timestamp
            + ',"imu":{"gyro":' + _vec(gyro, f) + ',"accel_body":' + _vec(accel_body, f) + '}'
            + ',"position":' + _vec(position, d) + ',"velocity":' + _vec(velocity, f)
            + ',"quaternion":' + _vec(quaternion, f)
            + (',"no_time_sync":1' if no_time_sync else '') + '}\n')
    return text.encode("ascii")
