"""Rows kept in memory (``run(output=None)``; ``Result.frame`` reads them)."""
from __future__ import annotations

import pyarrow as pa

from . import SINKS
from .base import Sink


@SINKS.register("memory")
class MemorySink(Sink):
    needs_folder = False
    takes_deferred = True       # blocks may come as DeferredBlock: their tables are built when read

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.blocks: list[pa.Table] = []

    def write(self, block):
        self.blocks.append(block)

    def mark(self):
        return len(self.blocks)

    def rollback(self, mark):
        del self.blocks[mark:]

    def table(self) -> pa.Table:
        self.blocks = [b if isinstance(b, pa.Table) else b.table() for b in self.blocks]
        return pa.concat_tables(self.blocks) if self.blocks else self.schema.empty_table()
