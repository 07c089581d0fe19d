"""Values written as text (SSD/SSV attributes, the command line, CSV cells) read as the type they stand for."""
from __future__ import annotations

import math

INTEGER_TYPES = ("Integer", "Int64", "UInt64", "Enumeration")


def parse_boolean(raw: str) -> bool:
    """xs:boolean: true, false, 1 or 0 (surrounding blanks and case ignored); ValueError otherwise."""
    low = raw.strip().lower()
    if low not in ("true", "false", "1", "0"):
        raise ValueError(raw)
    return low in ("true", "1")


def parse_real(raw: str) -> float:
    """A double: ``float`` but a finite number too large for one (1e400) is refused, not taken as infinity (which
    "inf" asks for)."""
    value = float(raw)
    if math.isinf(value) and "inf" not in raw.lower():
        raise ValueError(f"{raw.strip()}: out of range for a 64-bit float")
    return value


def parse_text(typ: str, raw: str):
    """``raw`` as a value of the SSP/master type ``typ`` (Real, an integer type, Boolean, Binary as hexadecimal
    digits, String as it is); ValueError when it is not one."""
    if typ == "Real":
        return parse_real(raw)
    if typ in INTEGER_TYPES:
        return int(raw)
    if typ == "Boolean":
        return parse_boolean(raw)
    if typ == "Binary":
        return bytes.fromhex(raw)
    return raw
