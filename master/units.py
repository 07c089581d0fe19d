"""Unit conversion between connectors, from SSD ssc:Unit definitions or the FMUs' UnitDefinitions."""
from __future__ import annotations

from .records import Record

BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


class Unit(Record):
    """A unit as SSP (ssc:Unit) and FMI (UnitDefinitions) define it: SI value = factor * value + offset. A plain
    class, not a dataclass (``master.records`` says why)."""
    def __init__(self, name: str, factor: float = 1.0, offset: float = 0.0,
                 exponents: tuple = (0, 0, 0, 0, 0, 0, 0, 0)):     # kg m s A K mol cd rad
        self.name, self.factor, self.offset, self.exponents = name, factor, offset, exponents


def unit_from_fmu(fmu_unit) -> Unit:
    bu = getattr(fmu_unit, "baseUnit", None)
    if bu is None:
        return Unit(fmu_unit.name)
    exps = tuple(int(getattr(bu, b, 0) or 0) for b in BASE_UNITS)
    return Unit(fmu_unit.name, float(bu.factor or 1.0), float(bu.offset or 0.0), exps)


def conversion(src: Unit | None, dst: Unit | None) -> tuple[float, float] | None:
    """(factor, offset) such that value_dst = factor * value_src + offset; None when units do not match.

    Both units map to SI as si = factor * value + offset (the SSP/FMI BaseUnit convention).
    """
    if src is None or dst is None or src.name == dst.name:
        return 1.0, 0.0
    if src.exponents != dst.exponents:
        return None
    factor = src.factor / dst.factor
    offset = (src.offset - dst.offset) / dst.factor
    return factor, offset
