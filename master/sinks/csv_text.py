"""The text of results.csv's cells and rows, the reference (``format_rows``): doubles as repr writes them (they
read back exactly), Booleans as true/false, integers in decimal, strings quoted where CSV needs it, FMI 3.0
Binary values as lowercase hexadecimal digits (as the FMI cross-check results write them). ``csv_native.py``
writes the same bytes faster; both import this module, the sink (``csv.py``) imports both."""
from __future__ import annotations

import pyarrow as pa

from ..arrow_numpy import to_numpy


def csv_quote(s: str) -> str:
    if any(ch in s for ch in ',"\n'):
        return '"' + s.replace('"', '""') + '"'
    return s


def _format(typ):
    """The function that turns a column's values into CSV text."""
    if pa.types.is_floating(typ):
        return lambda vals: [repr(float(x)) for x in vals]
    if pa.types.is_boolean(typ):
        return lambda vals: ["true" if x else "false" for x in vals]
    if pa.types.is_string(typ):
        return lambda vals: [csv_quote(str(x)) for x in vals]
    if pa.types.is_binary(typ):
        return lambda vals: [x.hex() for x in vals]
    return lambda vals: [str(int(x)) for x in vals]


def format_rows(block: pa.Table) -> str:
    """The CSV lines of ``block``'s rows (each ending in a newline): the reference."""
    cols = [_format(col.type)(to_numpy(col)) for col in block.columns]
    return "".join(",".join(r) + "\n" for r in zip(*cols))
