"""results.csv: a header, then one line per row; doubles written with repr (they read back exactly), FMI 3.0
Binary values as lowercase hexadecimal digits (as the FMI cross-check results write them)."""
from __future__ import annotations

import pyarrow as pa

from . import SINKS
from .base import Sink


def csv_quote(s: str) -> str:
    if any(ch in s for ch in ',"\n'):
        return '"' + s.replace('"', '""') + '"'
    return s


@SINKS.register("csv")
class CsvSink(Sink):
    file_name = "results.csv"

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / self.file_name
        self._fh = open(self.path, "w", encoding="utf-8", newline="")
        self._fh.write(",".join(csv_quote(c) for c in schema.names) + "\n")

    def write(self, block):
        cols = []
        for col in block.columns:
            typ = col.type
            vals = col.to_numpy(zero_copy_only=False)
            if pa.types.is_floating(typ):
                cols.append([repr(float(x)) for x in vals])
            elif pa.types.is_boolean(typ):
                cols.append(["true" if x else "false" for x in vals])
            elif pa.types.is_string(typ):
                cols.append([csv_quote(str(x)) for x in vals])
            elif pa.types.is_binary(typ):
                cols.append([x.hex() for x in vals])
            else:
                cols.append([str(int(x)) for x in vals])
        self._fh.write("".join(",".join(r) + "\n" for r in zip(*cols)))
        self._fh.flush()

    def mark(self):
        return self._fh.tell()

    def rollback(self, mark):
        self._fh.seek(mark)
        self._fh.truncate(mark)
        self._fh.flush()

    def close(self):
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def files(self):
        return [self.path]
