"""MAVLink 2 frames of the telemetry messages, packed straight from pymavlink's message definitions.

pymavlink builds a message object per message and packs it through generic code: ~4 µs a message, which for
a fleet streaming at 10 Hz is most of the stream's cost.  A ``Frame`` takes the wire layout (field order,
struct format, CRC extra, id) from pymavlink's message class once and packs a tuple of field values into the
same bytes pymavlink would (trailing zeros of the payload cut, X.25 CRC with the CRC extra; unsigned), with
the sequence number of the vehicle's pymavlink encoder, so that its messages and ours count on together.
"""
from __future__ import annotations

import struct

from pymavlink.generator.mavcrc import mcrf4xx, x25crc

HEADER = struct.Struct("<BBBBBBBHB")
STX_V2 = 0xFD


class Frame:
    """One message type: ``pack(enc, *values)`` with the values in the message's field order (an array field
    as one sequence)."""

    def __init__(self, cls):
        self.msgid = cls.id
        self.extra = bytes([cls.crc_extra])
        self.body = cls.unpacker
        self.order = [cls.fieldnames.index(n) for n in cls.ordered_fieldnames]
        self.identity = self.order == list(range(len(self.order)))
        self.arrays = any(cls.array_lengths)
        # extension fields left out by a caller are zero, as pymavlink's encoders make them
        self.defaults = tuple([0] * n if n else 0 for n in cls.array_lengths)

    def pack(self, enc, *values) -> bytes:
        if len(values) < len(self.defaults):
            values = values + self.defaults[len(values):]
        if self.arrays:
            wire = []
            for i in self.order:
                v = values[i]
                if isinstance(v, (list, tuple)):
                    wire.extend(v)
                else:
                    wire.append(v)
        elif self.identity:
            wire = values
        else:
            wire = [values[i] for i in self.order]
        payload = self.body.pack(*wire).rstrip(b"\0") or b"\0"
        seq = enc.seq
        enc.seq = (seq + 1) & 255
        frame = HEADER.pack(STX_V2, len(payload), 0, 0, seq, enc.srcSystem, enc.srcComponent,
                            self.msgid & 0xFFFF, self.msgid >> 16) + payload
        if mcrf4xx is not None:           # pymavlink's own choice: the C CRC of fastcrc when installed
            crc = mcrf4xx(frame[1:] + self.extra, 0xFFFF)
        else:
            acc = x25crc(frame[1:])
            acc.accumulate(self.extra)
            crc = acc.crc
        return frame + crc.to_bytes(2, "little")


def packed(enc, message) -> bytes:
    """A pymavlink message packed by the vehicle's encoder, counting its sequence on (pymavlink counts in
    ``MAVLink.send``, which a stream to several links does not use)."""
    data = message.pack(enc)
    enc.seq = (enc.seq + 1) & 255
    return data
