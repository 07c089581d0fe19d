"""Buffered, streaming recording of time series to Parquet and CSV.

Rows are assembled into a preallocated block and written a block at a time (one Parquet row group,
one CSV append), so memory stays bounded for long runs and every flushed block is on disk if the run
fails later. ``close`` always flushes what is left.
"""
from __future__ import annotations

import fnmatch
import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from .plan import Var

ARROW_TYPES = {"Real": pa.float64(), "Integer": pa.int32(), "Boolean": pa.bool_(), "String": pa.string()}


def select_variables(plan, patterns: list[str] | None, connected_outputs: list[Var]) -> list[Var]:
    """Default: every connected output. Patterns (shell-style, on 'component.variable') select more or others."""
    if not patterns:
        return list(connected_outputs)
    # one regular expression for all patterns (fnmatchcase semantics): a fleet has thousands of variables
    match = re.compile("|".join(f"(?:{fnmatch.translate(p)})" for p in patterns)).match
    chosen, seen = [], set()
    for comp, vars_ in plan.variables.items():
        for v in vars_.values():
            q = v.qualified
            if q in seen or v.type not in ARROW_TYPES:
                continue
            if match(q):
                chosen.append(v)
                seen.add(q)
    return chosen


class Recorder:
    def __init__(self, out_dir: Path | None, variables: list[Var], rt, block_rows: int | None = None,
                 csv: bool = True, parquet: bool = True):
        self.variables = variables
        self.columns = ["time"] + [v.qualified for v in variables]
        self.rt = rt
        # Blocks of 4096 rows whatever the width: a wide table (a 256-UAV fleet records ~8000 columns) cut
        # into short row groups costs far more memory when read back (measured: 128-row groups of 8000
        # columns, 9 GB to read one hour) than the block itself (4096 x 8000 x 8 B = 260 MB).
        self.block_rows = block_rows or 4096
        # numeric values (Real, Integer, Boolean) share one float64 block, grouped by type so that each type
        # fills a contiguous run of columns with one np.take per row
        self.num = sorted(((k, v) for k, v in enumerate(variables) if v.type != "String"),
                          key=lambda kv: ("Real", "Integer", "Boolean").index(kv[1].type))
        self.str_ = [(k, v) for k, v in enumerate(variables) if v.type == "String"]
        self.block = np.empty((self.block_rows, 1 + len(self.num)), dtype=np.float64)
        self.str_rows: list[list[str]] = []
        self.fill = 0
        self.rows_written = 0
        self.column_of = {k: col for col, (k, _) in enumerate(self.num, start=1)}
        self.gather = []
        col = 1
        for typ in ("Real", "Integer", "Boolean"):
            pos = [rt.out_pos[v.qualified] for _, v in self.num if v.type == typ]
            if pos:
                self.gather.append((rt.out[typ], np.array(pos, dtype=np.intp), col, col + len(pos)))
                col += len(pos)
        self.str_pos = [rt.out_pos[v.qualified] for _, v in self.str_]
        self.schema = pa.schema([pa.field("time", pa.float64())] +
                                [pa.field(v.qualified, ARROW_TYPES[v.type]) for v in variables])
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.parquet_path = self.csv_path = None
        self._pq = None
        self._csv = None
        if self.out_dir is not None:
            if parquet:
                self.parquet_path = self.out_dir / "results.parquet"
                # column statistics for thousands of columns times many row groups would make the footer,
                # which the writer keeps in memory until close, the largest thing in a long wide run
                self._pq = pq.ParquetWriter(str(self.parquet_path), self.schema,
                                            write_statistics=len(variables) <= 256)
            if csv:
                self.csv_path = self.out_dir / "results.csv"
                self._csv = open(self.csv_path, "w", encoding="utf-8", newline="")
                self._csv.write(",".join(_csv_quote(c) for c in self.columns) + "\n")
        self._memory: list[pa.Table] | None = [] if self.out_dir is None else None

    def sample(self, t: float) -> None:
        row = self.block[self.fill]
        row[0] = t
        for out, pos, a, b in self.gather:
            if out.dtype == np.float64:
                np.take(out, pos, out=row[a:b])
            else:
                row[a:b] = out[pos]
        if self.str_:
            s = self.rt.out["String"]
            self.str_rows.append([s[p] for p in self.str_pos])
        self.fill += 1
        if self.fill == self.block_rows:
            self.flush()

    def _table(self) -> pa.Table:
        blk = self.block[: self.fill]
        arrays = [pa.array(blk[:, 0])]
        str_cols = {k: j for j, (k, _) in enumerate(self.str_)}
        for k, v in enumerate(self.variables):
            if v.type == "String":
                arrays.append(pa.array([r[str_cols[k]] for r in self.str_rows], type=pa.string()))
                continue
            col = blk[:, self.column_of[k]]
            if v.type == "Integer":
                arrays.append(pa.array(col.astype(np.int32)))
            elif v.type == "Boolean":
                arrays.append(pa.array(col != 0))
            else:
                arrays.append(pa.array(col))
        return pa.Table.from_arrays(arrays, schema=self.schema)

    def flush(self) -> None:
        if self.fill == 0:
            return
        table = self._table()
        if self._pq is not None:
            self._pq.write_table(table)
        if self._csv is not None:
            self._write_csv(table)
        if self._memory is not None:
            self._memory.append(table)
        self.rows_written += self.fill
        self.fill = 0
        self.str_rows = []

    def _write_csv(self, table: pa.Table) -> None:
        cols = []
        for name, col in zip(table.column_names, table.columns):
            typ = col.type
            vals = col.to_numpy(zero_copy_only=False)
            if pa.types.is_floating(typ):
                cols.append([repr(float(x)) for x in vals])   # repr round-trips a double exactly
            elif pa.types.is_boolean(typ):
                cols.append(["true" if x else "false" for x in vals])
            elif pa.types.is_string(typ):
                cols.append([_csv_quote(str(x)) for x in vals])
            else:
                cols.append([str(int(x)) for x in vals])
        self._csv.write("".join(",".join(r) + "\n" for r in zip(*cols)))
        self._csv.flush()

    def close(self) -> None:
        try:
            self.flush()
        finally:
            if self._pq is not None:
                self._pq.close()
                self._pq = None
            if self._csv is not None:
                self._csv.close()
                self._csv = None

    def memory_table(self) -> pa.Table | None:
        if self._memory is None:
            return None
        return pa.concat_tables(self._memory) if self._memory else self.schema.empty_table()


def _csv_quote(s: str) -> str:
    if any(ch in s for ch in ',"\n'):
        return '"' + s.replace('"', '""') + '"'
    return s
