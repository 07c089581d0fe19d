"""Values compared bit for bit: what the C extensions' tests compare between the compiled step and its Python twin
(the shell's whole state: floats as IEEE bits, arrays as bytes, random generators by their state)."""
from __future__ import annotations

import struct


def bits(v):
    """A value with its type, floats as their IEEE bits (0.0 and -0.0 differ, a NaN equals itself)."""
    if type(v) is float:
        return "f", struct.pack("<d", v)
    if type(v) in (list, tuple):
        return type(v).__name__, tuple(bits(x) for x in v)
    if type(v) is dict:
        return "dict", tuple((bits(k), bits(x)) for k, x in v.items())
    if hasattr(v, "tobytes"):
        return "array", v.dtype.str, v.shape, v.tobytes()
    if hasattr(v, "bit_generator"):
        return "rng", bits(v.bit_generator.state)
    if hasattr(v, "__slots__"):
        return type(v).__name__, tuple((n, bits(getattr(v, n, None))) for n in v.__slots__)
    if hasattr(v, "__dataclass_fields__"):
        return type(v).__name__, bits(vars(v))
    return type(v).__name__, v
