"""results.parquet: one row group per block."""
from __future__ import annotations

import pyarrow.parquet as pq

from . import SINKS
from .base import Sink


@SINKS.register("parquet")
class ParquetSink(Sink):
    file_name = "results.parquet"

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / self.file_name
        # column statistics for thousands of columns times many row groups would make the footer, which the
        # writer keeps in memory until close, the largest thing in a long wide run
        self._writer = pq.ParquetWriter(str(self.path), schema, write_statistics=len(schema) <= 257)

    def write(self, block):
        self._writer.write_table(block)

    def close(self):
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def files(self):
        return [self.path]
