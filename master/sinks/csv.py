"""results.csv: a header, then one line per row; doubles written with repr (they read back exactly), FMI 3.0
Binary values as lowercase hexadecimal digits (as the FMI cross-check results write them).

``csv_text.format_rows`` is the one reference for the text of the rows; ``csv_native.py`` (C, an accelerator
declared in master/accel.py's way) writes the same bytes for tables of numbers and Booleans ~20 times faster,
and with ``COSIM_MASTER_PURE_PYTHON=1`` or without a C compiler the reference writes them."""
from __future__ import annotations

from . import SINKS
from .base import Sink
from .csv_native import Scratch, formatter, native_chunks
from .csv_text import csv_quote, format_rows


CSV_CELLS = 1 << 16         # cells turned into text at a time (by the reference)


@SINKS.register("csv")
class CsvSink(Sink):
    file_name = "results.csv"
    _fh = None

    @property
    def concurrent(self) -> bool:
        """Whether its rows are formatted by C, without the GIL (SinkGroup then writes it beside the others)."""
        return formatter() is not None

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / self.file_name
        # unbuffered: a write that fails (a full disk) leaves nothing pending in a buffer, so the file can be cut
        # back to its last whole line (``rollback``) and every line before it is on disk
        self._fh = open(self.path, "wb", buffering=0)
        self._put(",".join(csv_quote(c) for c in schema.names) + "\n")

    def _put(self, text: str) -> None:
        self._put_bytes(memoryview(text.encode("utf-8")))

    def _put_bytes(self, data: memoryview) -> None:
        while data:                 # a raw write may take part of the bytes (the last room on a disk)
            data = data[self._fh.write(data):]

    def write(self, block):
        if getattr(self, "_scratch", None) is None:
            self._scratch = Scratch()
        chunks = native_chunks(block, self._scratch)
        if chunks is not None:
            for data in chunks:
                self._put_bytes(data)
            return
        # a slice of rows at a time: every cell becomes a Python string first, ~60 bytes each, so a whole
        # block of a wide table (thousands of columns) at once would cost many times the block
        step = max(1, CSV_CELLS // max(1, block.num_columns))
        for start in range(0, block.num_rows, step):
            self._put(format_rows(block.slice(start, step)))

    def mark(self):
        return self._fh.tell()

    def rollback(self, mark):
        self._fh.truncate(mark)
        self._fh.seek(mark)

    def close(self):
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        self._scratch = None

    def files(self):
        return [self.path]
