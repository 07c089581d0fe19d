"""results.csv: a header, then one line per row; doubles written with repr (they read back exactly), FMI 3.0
Binary values as lowercase hexadecimal digits (as the FMI cross-check results write them)."""
from __future__ import annotations

import pyarrow as pa

from ..arrow_numpy import to_numpy
from . import SINKS
from .base import Sink


def csv_quote(s: str) -> str:
    if any(ch in s for ch in ',"\n'):
        return '"' + s.replace('"', '""') + '"'
    return s


CSV_CELLS = 1 << 16         # cells turned into text at a time


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


@SINKS.register("csv")
class CsvSink(Sink):
    file_name = "results.csv"
    _fh = None

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / self.file_name
        # unbuffered: a write that fails (a full disk) leaves nothing pending in a buffer, so the file can be cut
        # back to its last whole line (``rollback``) and every line before it is on disk
        self._fh = open(self.path, "wb", buffering=0)
        self._put(",".join(csv_quote(c) for c in schema.names) + "\n")

    def _put(self, text: str) -> None:
        data = memoryview(text.encode("utf-8"))
        while data:                 # a raw write may take part of the bytes (the last room on a disk)
            data = data[self._fh.write(data):]

    def write(self, block):
        formats = [(_format(col.type), to_numpy(col)) for col in block.columns]
        # a slice of rows at a time: every cell becomes a Python string first, ~60 bytes each, so a whole
        # block of a wide table (thousands of columns) at once would cost many times the block
        step = max(1, CSV_CELLS // max(1, len(formats)))
        for start in range(0, block.num_rows, step):
            cols = [fmt(vals[start:start + step]) for fmt, vals in formats]
            self._put("".join(",".join(r) + "\n" for r in zip(*cols)))

    def mark(self):
        return self._fh.tell()

    def rollback(self, mark):
        self._fh.truncate(mark)
        self._fh.seek(mark)

    def close(self):
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def files(self):
        return [self.path]
