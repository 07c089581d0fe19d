"""Recording: an observer that samples the recorded variables on the record grid into blocks of rows and
hands each full block to the output sinks (Parquet, CSV, memory, ...).

Rows are assembled into a preallocated block and written a block at a time, so memory stays bounded for
long runs and every flushed block is on disk if the run fails later. ``finish`` always flushes what is left.
"""
from __future__ import annotations

import fnmatch
import functools
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..fmi.slave import OBJECT_FILL
from ..plan import Var
from ..sinks.group import SinkGroup
from .base import Observer

if TYPE_CHECKING:
    import pyarrow as pa

# pyarrow is imported where a table or a schema is made, not with this module: a supervised run's simulation
# process records into shared memory and names its columns to the supervisor as plain data (``columns``); the
# supervisor, which writes the files, makes the schema (``schema_of``) and imports pyarrow while the child starts
RECORDABLE_TYPES = ("Real", "Integer", "Int64", "UInt64", "Boolean", "String", "Binary")
# FMI 3.0 integers get a column of their own width (FMI 2.0 Integer and enumerations stay int32)
FMI3_INTEGERS = ("Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64")


@functools.cache
def _arrow_tables() -> dict:
    """The Arrow type of each column type (``column_type``) and the buffer type (``NUMERIC_ORDER``, ``OBJECT_FILL``)
    that holds each Arrow type's values in a block."""
    import pyarrow as pa
    arrow_types = {"Real": pa.float64(), "Integer": pa.int32(), "Int64": pa.int64(), "UInt64": pa.uint64(),
                   "Boolean": pa.bool_(), "String": pa.string(), "Binary": pa.binary()}
    fmi3_int_arrow = {"Int8": pa.int8(), "UInt8": pa.uint8(), "Int16": pa.int16(), "UInt16": pa.uint16(),
                      "Int32": pa.int32(), "UInt32": pa.uint32(), "Int64": pa.int64(), "UInt64": pa.uint64()}
    base_of = {pa.float64(): "Real", pa.int8(): "Integer", pa.uint8(): "Integer", pa.int16(): "Integer",
               pa.uint16(): "Integer", pa.int32(): "Integer", pa.uint32(): "Int64", pa.int64(): "Int64",
               pa.uint64(): "UInt64", pa.bool_(): "Boolean", pa.string(): "String", pa.binary(): "Binary"}
    return {"ARROW_TYPES": arrow_types, "FMI3_INT_ARROW": fmi3_int_arrow, "_BASE_OF": base_of,
            "by_column_type": {**arrow_types, **fmi3_int_arrow}}


def __getattr__(name: str):
    # the tables of Arrow types as module attributes, made (and pyarrow imported) when first asked for
    if name in ("ARROW_TYPES", "FMI3_INT_ARROW", "_BASE_OF"):
        return _arrow_tables()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def column_type(v: Var) -> str:
    """The name of a recorded variable's column type: its FMI 3.0 integer type or its base type."""
    return v.fmi_type if v.fmi_type in FMI3_INTEGERS else v.type


def arrow_type(v: Var) -> pa.DataType:
    return _arrow_tables()["by_column_type"][column_type(v)]


def schema_of(columns: list[tuple[str, str]]) -> pa.Schema:
    """The results' schema: time, then each (name, column type) of ``columns``."""
    import pyarrow as pa
    types = _arrow_tables()["by_column_type"]
    return pa.schema([pa.field("time", pa.float64())] + [pa.field(name, types[typ]) for name, typ in columns])


def select_variables(plan, patterns: list[str] | None, connected_outputs: list[Var]) -> list[Var]:
    """Default: every connected output. Patterns (shell-style, on 'component.variable') select more or others."""
    if not patterns:
        return list(connected_outputs)
    match = _pattern_matcher(tuple(patterns))
    chosen, seen = [], set()
    for comp, vars_ in plan.variables.items():
        prefix = comp + "."
        for name in _matching_names(match, comp, vars_):
            q = prefix + name
            if q in seen:
                continue
            chosen.append(vars_[name])
            seen.add(q)
    return chosen


@functools.lru_cache(maxsize=16)
def _pattern_matcher(patterns: tuple):
    # one regular expression for all patterns (fnmatchcase semantics): a fleet has thousands of variables; a
    # pattern is also taken literally, so that an array element (``m.y[2]``) names itself, not a [set]
    return re.compile("|".join(f"(?:{fnmatch.translate(p)})|(?:{re.escape(p)}\\Z)" for p in patterns)).match


# (matcher, component name, id of the FMU's shared description) -> (that description, kept alive for its id;
# the recordable names it matches): a campaign worker records the same patterns of the same FMUs in run after
# run, and matching a strategy FMU's thousand names was most of a run's setup time
_MATCHED: dict[tuple, tuple[dict, list[str]]] = {}
_MAX_MATCHED = 4096


def _matching_names(match, comp: str, vars_) -> list[str]:
    """The recordable variables of one component whose qualified name ``match`` takes, in the FMU's order."""
    described = getattr(vars_, "described", None)      # a plain mapping (input tables) is matched every time
    key = (match, comp, id(described))
    hit = _MATCHED.get(key) if described is not None else None
    if hit is not None and hit[0] is described:
        return hit[1]
    prefix = comp + "."
    names = []
    for name in vars_:          # by name: the plan makes a Var only for what is asked for (plan.ComponentVariables)
        if not match(prefix + name):
            continue
        v = vars_[name] if described is None else described[name]
        # an array is recorded as its elements, one column each (m.y[1], m.y[2], ...)
        if v.type not in RECORDABLE_TYPES or v.is_array:
            continue
        names.append(name)
    if described is not None:
        if len(_MATCHED) >= _MAX_MATCHED:
            _MATCHED.clear()
        _MATCHED[key] = (described, names)
    return names


# The numeric block is float64, 8 bytes a cell (a supervised run keeps it in shared memory). Real, int32 and
# Boolean values are stored as doubles (exact for them); 64-bit integers are stored as their bits (a view of the
# cell as int64/uint64, never a conversion to double, which would lose every value above 2**53).
NUMERIC_ORDER = ("Real", "Integer", "Int64", "UInt64", "Boolean")
BIT_STORED = ("Int64", "UInt64")


def block_table(schema: pa.Schema, block: np.ndarray, str_rows: list[list]) -> pa.Table:
    """A block of rows as a table: ``block`` holds time then the numeric columns grouped by buffer type
    (``NUMERIC_ORDER``, each in schema order), ``str_rows`` the object (String and Binary) columns of each row,
    in schema order."""
    import pyarrow as pa

    from ..arrow_numpy import from_numpy, from_objects
    fields = list(schema)[1:]
    base_of = _arrow_tables()["_BASE_OF"]
    kinds = [base_of[f.type] for f in fields]
    numeric = sorted((k for k, kind in enumerate(kinds) if kind not in OBJECT_FILL),
                     key=lambda k: NUMERIC_ORDER.index(kinds[k]))
    column_of = {k: col for col, k in enumerate(numeric, start=1)}
    # one transposing copy, after which each column is contiguous and Arrow wraps it without another: a column
    # of the row-major block taken alone was a strided copy each (most of a wide table's cost here). Always a
    # copy: the recording fills its block again, and the transpose of one row or one column is already contiguous
    # (np.ascontiguousarray gave a view of the block, which a memory sink then kept)
    columns = block.T.copy()
    arrays = [from_numpy(columns[0])]
    j = 0
    for k, kind in enumerate(kinds):
        typ = fields[k].type
        if kind in OBJECT_FILL:
            arrays.append(from_objects([r[j] for r in str_rows], typ))
            j += 1
            continue
        col = columns[column_of[k]]
        if kind in BIT_STORED:      # UInt32 is kept in the Int64 buffer: its values narrowed to their width
            arrays.append(from_numpy(col.view(np.dtype(kind.lower())), typ))
        elif kind == "Integer":
            arrays.append(from_numpy(col, typ))
        elif kind == "Boolean":
            arrays.append(from_numpy(col != 0, typ))
        else:
            arrays.append(from_numpy(col, typ))
    return pa.Table.from_arrays(arrays, schema=schema)


class DeferredBlock:
    """A block of rows whose Arrow table is built when a sink asks for it: a campaign run keeps its rows in
    memory (``sinks: [memory]``) and never reads them, and building the table was most of its recording's
    cost at close.  Holds its own copy of the rows (the recording's block is reused)."""
    __slots__ = ("schema", "block", "str_rows")

    def __init__(self, schema: pa.Schema, block: np.ndarray, str_rows: list[list]):
        self.schema, self.block, self.str_rows = schema, block.copy(), str_rows

    @property
    def num_rows(self) -> int:
        return len(self.block)

    def table(self) -> pa.Table:
        return block_table(self.schema, self.block, self.str_rows)


# A block (and so a Parquet row group) holds at most MAX_BLOCK_ROWS rows and about BLOCK_BYTES of cells: a
# narrow table gets long row groups (few, cheap to read), a wide one short blocks, so that the block, its
# Arrow copy and the writer's buffers stay a few tens of MB whatever the fleet (a fixed 4096 rows of a 256-UAV
# fleet's ~5700 columns was 190 MB, held three times over at a flush).  Reading many short row groups back
# is no dearer with ``master.results.read_results``, which fills one array per type group by group.
BLOCK_BYTES = 16 << 20
MAX_BLOCK_ROWS = 4096
MIN_BLOCK_ROWS = 16


def block_rows_for(columns: int, budget: int | None = None) -> int:
    """Rows per block for a table of ``columns`` 8-byte cells (time included) within ``budget`` bytes
    (default ``BLOCK_BYTES``)."""
    budget = BLOCK_BYTES if budget is None else budget
    return max(MIN_BLOCK_ROWS, min(MAX_BLOCK_ROWS, budget // (8 * max(1, columns))))


def _filler(out: np.ndarray, pos: np.ndarray, a: int, b: int):
    """``fill(row)`` putting the values of ``out`` at ``pos`` into the cells a:b of a row of the block: a float64
    buffer's values, a 64-bit integer buffer's bits (see NUMERIC_ORDER), other types converted to float64.  The
    types are told apart once here, not at every sample (comparing dtypes cost more than the copies); 'clip' takes
    the same values as 'raise' (the positions are valid) without the copy of the target 'raise' makes."""
    take = out.take
    if out.dtype == np.float64:
        def fill(row):
            take(pos, None, row[a:b], "clip")
    elif out.dtype.itemsize == 8:
        bits = out.dtype

        def fill(row):
            take(pos, None, row[a:b].view(bits), "clip")
    else:
        def fill(row):
            row[a:b] = out[pos]
    return fill


class Recording(Observer):
    """Samples at the start, every ``every`` steps, at the last step and when the run ends early."""
    name = "recording"

    def __init__(self, variables: list[Var], sinks: list, out_dir: Path | None, every: int = 1,
                 steps: int | None = None, block_rows: int | None = None):
        self.variables = variables
        self.sinks = sinks
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.every = every
        self.steps = steps
        self.block_rows = block_rows or block_rows_for(1 + len(variables))
        self.group = SinkGroup(sinks, self.out_dir)
        self.columns = [(v.qualified, column_type(v)) for v in variables]

    @functools.cached_property
    def schema(self) -> pa.Schema:
        return schema_of(self.columns)

    @property
    def rows_written(self) -> int:
        return self.group.rows

    def sampled_variables(self) -> list[str]:
        return [v.qualified for v in self.variables]

    def attach(self, ctx, start: float) -> None:
        super().attach(ctx, start)
        rt = self.rt = ctx.rt
        variables = self.variables
        # numeric values share one 8-byte-a-cell block, grouped by buffer type so that each type fills a
        # contiguous run of columns with one np.take per row; String and Binary values are kept per row as
        # Python objects (``str_``, named for the strings that came first)
        self.num = sorted(((k, v) for k, v in enumerate(variables) if v.type not in OBJECT_FILL),
                          key=lambda kv: NUMERIC_ORDER.index(kv[1].type))
        self.str_ = [(k, v) for k, v in enumerate(variables) if v.type in OBJECT_FILL]
        self.block = self._new_block(self.block_rows, 1 + len(self.num))
        self.str_rows: list[list] = []
        self.fill = 0
        self.gather = []
        col = 1
        for typ in NUMERIC_ORDER:
            pos = [rt.out_pos[v.qualified] for _, v in self.num if v.type == typ]
            if pos:
                self.gather.append((rt.out[typ], np.array(pos, dtype=np.intp), col, col + len(pos)))
                col += len(pos)
        self.str_pos = [(rt.out[v.type], rt.out_pos[v.qualified]) for _, v in self.str_]
        self._fills = [_filler(out, pos, a, b) for out, pos, a, b in self.gather]
        self._open_sinks()
        self.sample(start)

    def _open_sinks(self) -> None:
        self.group.open(self.schema)

    def _new_block(self, rows: int, cols: int) -> np.ndarray:
        return np.empty((rows, cols), dtype=np.float64)

    def samples_after(self, n: int) -> bool:
        """Whether a row is taken after step n: every ``every`` steps, after the last step (``steps``) and when the
        run ends early. A step driver that records itself takes its rows exactly there."""
        return (n + 1) % self.every == 0 or n + 1 == self.steps or self.rt.stop_reason is not None

    @property
    def has_object_columns(self) -> bool:
        """Whether String or Binary values are recorded (kept per row as Python objects, outside ``block``)."""
        return bool(self.str_)

    def after_step(self, n: int, t0: float, t1: float) -> None:
        rt = self.rt
        # the test of samples_after, written out: it runs after every step, and a call is most of its cost
        if (n + 1) % self.every == 0 or n + 1 == self.steps or rt.stop_reason is not None:
            rt.read_samples(t1)
            self.sample(t1)

    def sample(self, t: float) -> None:
        row = self.block[self.fill]
        row[0] = t
        for fill in self._fills:
            fill(row)
        if self.str_:
            self.str_rows.append(self.object_row())
        self.fill += 1
        if self.fill == self.block_rows:
            self.flush()

    def object_row(self) -> list:
        """The String and Binary values of the current row, in schema order."""
        return [buf[p] for buf, p in self.str_pos]

    def _table(self) -> pa.Table:
        return block_table(self.schema, self.block[: self.fill], self.str_rows)

    def flush(self) -> None:
        if getattr(self, "fill", 0) == 0:
            return
        if self.group.defers:
            table = DeferredBlock(self.schema, self.block[: self.fill], self.str_rows)
        else:
            table = self._table()
        # the rows are consumed before they are written: whatever happens below, no row is written twice
        self.fill = 0
        self.str_rows = []
        self.group.write(table)

    def finish(self, out_dir, outcome) -> dict:
        try:
            self.flush()
        finally:
            self.group.close()
            # the block is not needed any more; monitors read the results back after this (UAV outputs)
            self.block = None
        info = {"rows": self.rows_written}
        if self.group.notes:
            info["notes"] = self.group.notes
        return info

    def files(self) -> list[Path]:
        return self.group.files()
