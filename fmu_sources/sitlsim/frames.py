"""The two packets of SITL's JSON physics protocol (../shared/sitl/README.md; ArduPilot
libraries/SITL/examples/JSON/readme.md).

SITL -> physics, one UDP datagram per physics step, little-endian::

    uint16 magic (18458; 29569 with SERVO_32_ENABLE), uint16 frame_rate, uint32 frame_count, uint16 pwm[16|32]

physics -> SITL: one JSON object framed by newlines.  SITL's parser is a string search, not a JSON parser:
it takes the text between the last two newlines it holds, finds ``"key":`` and reads the number right after
the colon, so there must be no space after a colon, and the object is both preceded and followed by "\\n"
(the leading one makes every datagram a complete line even for SITL's very first read).

``answer(...)`` prints every number in fixed point with 9 decimals from an integer (round-half-even of
v * 1e9, the same integer in C's llrint and Python's round), and the timestamp from an integer count of
nanoseconds, so the Python and the compiled twin (physics.c: sitl_format) produce the same bytes (tested)
without any float-to-decimal conversion, which would cost more than the physics step itself.
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


#: decimals of every number in the answer: 1 nm, 1 nm/s, 1 nrad/s, 1e-9 of a quaternion component
DECIMALS = 9
_SCALE = 10 ** DECIMALS
_LIMIT = 9_000_000_000_000_000_000        # |scaled value| limit: int64 in the compiled twin


def fixed(v: float) -> str:
    """v with exactly 9 decimals, from the integer round-half-even(v * 1e9) (so no float-to-decimal
    conversion: the compiled twin does the same with llrint and integer digits, ~20x cheaper than printf)."""
    x = v * 1e9
    if v != v:
        n = 0
    elif x >= 9.0e18:
        n = _LIMIT
    elif x <= -9.0e18:
        n = -_LIMIT
    else:
        n = max(-_LIMIT, min(_LIMIT, round(x)))
    a, b = divmod(-n if n < 0 else n, _SCALE)
    return f"{'-' if n < 0 else ''}{a}.{b:09d}"


def _vec(values) -> str:
    return "[" + ",".join(fixed(v) for v in values) + "]"


def seconds(ns: int) -> str:
    """An integer number of nanoseconds as exact decimal seconds."""
    a, b = divmod(ns, _SCALE)
    return f"{a}.{b:09d}"


def answer(timestamp_ns: int, gyro, accel_body, position, velocity, quaternion, no_time_sync: bool = True) -> bytes:
    """The physics' answer: newline-framed JSON; timestamp in integer ns, printed exactly; quaternion
    (w, x, y, z) body-to-NED attitude; every other number with 9 decimals (``fixed``)."""
    text = ('\n{"timestamp":' + seconds(timestamp_ns)
            + ',"imu":{"gyro":' + _vec(gyro) + ',"accel_body":' + _vec(accel_body) + '}'
            + ',"position":' + _vec(position) + ',"velocity":' + _vec(velocity)
            + ',"quaternion":' + _vec(quaternion)
            + (',"no_time_sync":1' if no_time_sync else '') + '}\n')
    return text.encode("ascii")
