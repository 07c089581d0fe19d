"""The values a variable takes: a command-line, API or start value parsed in the variable's type and checked
against its integer type's range and for finiteness."""
from __future__ import annotations

import math

from ..errors import ScenarioError
from ..fmi.slave import INTEGER_BASES
from ..values import parse_text
from .model import Var


#: the values an FMI integer type holds (FMI 2.0 Integer and enumerations are 32-bit)
INT_RANGES = {"Integer": (-2**31, 2**31 - 1), "Enumeration": (-2**31, 2**31 - 1),
              "Int8": (-2**7, 2**7 - 1), "UInt8": (0, 2**8 - 1), "Int16": (-2**15, 2**15 - 1),
              "UInt16": (0, 2**16 - 1), "Int32": (-2**31, 2**31 - 1), "UInt32": (0, 2**32 - 1),
              "Int64": (-2**63, 2**63 - 1), "UInt64": (0, 2**64 - 1)}


def int_range(v: Var) -> tuple[int, int]:
    return INT_RANGES.get(v.fmi_type, INT_RANGES["Integer"])


def value_error(v: Var, value, allow_nonfinite: bool = False) -> str | None:
    """Why ``value`` cannot be given to ``v`` (out of its integer type's range, not finite), or None.
    An out-of-range integer would be cut to its low bits by a binary FMU but kept whole by a Python one."""
    if v.type in INTEGER_BASES and not isinstance(value, bool) and isinstance(value, int):
        lo, hi = int_range(v)
        if not lo <= value <= hi:
            return f"{value} is out of range for {v.qualified} ({v.fmi_type}: {lo}..{hi})"
    if v.type == "Real" and not allow_nonfinite and isinstance(value, float) and not math.isfinite(value):
        return (f"{value} is not a finite value for {v.qualified} (non-finite values are refused unless "
                "--allow-nonfinite is given)")
    return None


def parse_value(v: Var, raw, where: str, allow_nonfinite: bool = False):
    """A command-line (or API) value in the variable's type, checked for range and finiteness; an array's value
    is a sequence or a string of its elements separated by spaces or commas, row-major."""
    if v.is_array:
        return _parse_array(v, raw, where, allow_nonfinite)
    value = raw
    if isinstance(raw, str):
        try:
            value = parse_text(v.type, raw)      # Binary as FMI 3 writes its start values: hexadecimal digits
        except ValueError:
            raise ScenarioError(f"{raw!r} is not a valid {v.fmi_type} for {v.qualified}",
                                element=f"--param {where}") from None
    elif v.type == "Real" and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    why = value_error(v, value, allow_nonfinite)
    if why:
        raise ScenarioError(why, element=f"--param {where}")
    return value


def _parse_array(v: Var, raw, where: str, allow_nonfinite: bool) -> list:
    items = raw.replace(",", " ").split() if isinstance(raw, str) else list(raw)
    size = int(math.prod(v.shape))
    if len(items) != size:
        raise ScenarioError(f"{v.qualified} has {size} elements (shape {list(v.shape)}), {len(items)} were given",
                            element=f"--param {where}")
    element = v.changed(shape=(), index=None)
    return [parse_value(element, x, where, allow_nonfinite) for x in items]
