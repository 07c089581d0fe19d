"""Values compared bit for bit: what the C extensions' tests compare between the compiled step and its Python twin
(the shell's whole state: floats as IEEE bits, arrays as bytes, random generators by their state)."""
from __future__ import annotations

import struct


#: values that stand for themselves: answered before the attribute probes below, which none of them passes (where
#: the accelerator harness's pickles of two states differ, it calls ``bits`` on every one of their hundreds of ints,
#: flags and names)
_PLAIN = frozenset((int, bool, str, type(None)))
_pack = struct.Struct("<d").pack


def bits(v):
    """A value with its type, floats as their IEEE bits (0.0 and -0.0 differ, a NaN equals itself)."""
    t = type(v)
    if t is float:
        return "f", _pack(v)
    if t in _PLAIN:
        return t.__name__, v
    if t is list or t is tuple:        # float items inline: the same as bits(x), without a call per number
        return t.__name__, tuple([("f", _pack(x)) if type(x) is float else bits(x) for x in v])
    if t is dict:
        return "dict", tuple([(bits(k), bits(x)) for k, x in v.items()])
    if hasattr(v, "tobytes"):
        return "array", v.dtype.str, v.shape, v.tobytes()
    if hasattr(v, "bit_generator"):
        return "rng", bits(v.bit_generator.state)
    if hasattr(v, "__slots__"):
        return t.__name__, tuple([(n, bits(getattr(v, n, None))) for n in v.__slots__])
    if hasattr(v, "__dataclass_fields__"):
        return t.__name__, bits(vars(v))
    return t.__name__, v
