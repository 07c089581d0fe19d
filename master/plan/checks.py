"""An SSD connector against the FMU variable it names, and a connection against the two variables it joins:
kind, type and a width every value fits."""
from __future__ import annotations

from ..errors import ScenarioError
from ..fmi.slave import INTEGER_BASES, OBJECT_FILL
from ..ssp.model import Connector
from .model import Var
from .variable_values import int_range


# SSD connector kinds and the FMU causalities they may describe
KIND_CAUSALITY = {
    "input": {"input"},
    "output": {"output"},
    "parameter": {"parameter", "structuralParameter"},
    "calculatedParameter": {"calculatedParameter"},
}
# SSD connector types and the FMU variable types they may describe
SSD_TYPE_FMI = {
    "Real": {"Real", "Float64", "Float32"},
    # an FMU enumeration is an integer to a connector; ssc:Enumeration would need a named SSD enumeration, which
    # our writer and most tools do not write
    "Integer": {"Integer", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64", "Enumeration"},
    "Boolean": {"Boolean"},
    "String": {"String"},
    "Enumeration": {"Enumeration"},
    "Binary": {"Binary"},
}


def check_connector(conn: Connector, v: Var, shown_as: str) -> None:
    """The SSD connector ``conn`` describes ``v``: its kind, type and a type the master can connect."""
    here = f"Connector {v.qualified}"
    allowed = KIND_CAUSALITY.get(conn.kind)
    if allowed is None:
        raise ScenarioError(f"connector kind {conn.kind!r} is not allowed on a component", file=shown_as,
                            element=here, line=conn.line)
    if v.causality not in allowed:
        raise ScenarioError(f"kind {conn.kind!r} does not match the FMU's causality {v.causality!r}",
                            file=shown_as, element=here, line=conn.line)
    if conn.type is not None and v.fmi_type not in SSD_TYPE_FMI.get(conn.type, set()):
        raise ScenarioError(f"type {conn.type} does not match the FMU's type {v.fmi_type}", file=shown_as,
                            element=here, line=conn.line)
    if v.type not in ("Real", *INTEGER_BASES, "Boolean", *OBJECT_FILL):
        raise ScenarioError(f"variables of type {v.fmi_type} cannot be connected", file=shown_as,
                            element=here, line=conn.line)


def connection_type_error(src: Var, dst: Var) -> str | None:
    """Why a connection from ``src`` to ``dst`` cannot carry every value, or None. Integers connect when every
    value of the start's type fits the end's (a narrowing would cut values to their low bits) and both travel
    in the same buffer (Int8..Int32 and FMI 2.0 Integer in int32, UInt32 and Int64 in int64, UInt64 alone)."""
    mismatch = f"type mismatch: {src.qualified} is {src.fmi_type}, {dst.qualified} is {dst.fmi_type}"
    if src.type in INTEGER_BASES and dst.type in INTEGER_BASES:
        (lo, hi), (dlo, dhi) = int_range(src), int_range(dst)
        if not dlo <= lo <= hi <= dhi:
            return f"{mismatch}, and not every {src.fmi_type} value ({lo}..{hi}) fits {dst.fmi_type} ({dlo}..{dhi})"
        if src.type != dst.type:
            return (f"{mismatch}: the values would have to change width ({src.type} to {dst.type} buffers), "
                    "which connections do not do; connect variables of the same width")
        return None
    return mismatch if src.type != dst.type else None
