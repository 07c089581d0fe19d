"""results.parquet: a row group per few blocks (up to ``ROW_GROUP_BYTES`` of them; one per block for a wide table)."""
from __future__ import annotations

import pyarrow as pa

from . import SINKS
from .base import Sink

#: a row group holds the blocks written since the last one while about one more would still fit in this many bytes
#: (the same budget as the recording's block, master.observers.recording.BLOCK_BYTES): on the 121-column bench tables
#: (bench/results/recording_2026-11-29b.md) four blocks of 4096 rows a row group wrote in 0.29 s instead of 0.34 s
#: CPU (fewer, longer column chunks for snappy and the byte planes) and a smaller file; a block of half the budget
#: or more (a wide fleet's) is written at once, so that the table held never grows beyond one budget
ROW_GROUP_BYTES = 16 << 20


@SINKS.register("parquet")
class ParquetSink(Sink):
    file_name = "results.parquet"
    _writer = None
    concurrent = True       # pyarrow encodes and writes without the GIL (SinkGroup writes it beside the others)

    def open(self, out_dir, schema):
        # imported here, not with the module: the registry imports every sink module, and pyarrow.parquet (with
        # pyarrow.fs and ssl, ~60 ms) would be paid by every campaign worker, whose runs keep their rows in memory
        import pyarrow.parquet as pq
        super().open(out_dir, schema)
        self.path = out_dir / self.file_name
        self._writer = pq.ParquetWriter(str(self.path), schema, **writer_options(schema))
        self._held: list[pa.Table] = []     # blocks not yet in the file: the next row group
        self._held_bytes = 0
        self._groups = 0                    # row groups begun (a failed write may have written part of one)

    def write(self, block):
        self._held.append(block)
        self._held_bytes += block.nbytes
        if self._held_bytes + self._held_bytes / len(self._held) > ROW_GROUP_BYTES:
            held, self._held, self._held_bytes = self._held, [], 0
            self._groups += 1
            _write_group(self._writer, held)

    def mark(self):
        return self._groups, len(self._held)

    def rollback(self, mark):
        """Blocks only held are let go; once a row group has been begun since ``mark``, the file cannot be cut back
        (its footer is written at the end): the sink is ``broken`` and rebuilt from the CSV (``repair``)."""
        groups, held = mark
        if self._groups != groups:
            self.broken = True
            return
        del self._held[held:]
        self._held_bytes = sum(t.nbytes for t in self._held)

    def close(self):
        if self._writer is not None:
            writer, self._writer = self._writer, None
            held, self._held = self._held, []
            if self.broken:
                try:
                    writer.close()
                except OSError:
                    pass
                return
            try:
                _write_group(writer, held)
            except OSError:         # the group (broken by it) rebuilds the file from the CSV
                try:
                    writer.close()
                except OSError:
                    pass
                raise
            writer.close()

    def repair(self, sinks, schema, rows):
        """A Parquet file cannot be cut back to its last whole row group (its footer is written at the end),
        so after a failed write it is rebuilt from the CSV, which can, and whose doubles read back exactly."""
        import os

        import pyarrow.csv as pc
        import pyarrow.parquet as pq

        from .csv import CsvSink
        csv = next((s for s in sinks if isinstance(s, CsvSink) and not s.broken), None)
        if csv is None:
            kept = self.path.with_name(self.path.name + ".incomplete")
            os.replace(self.path, kept)
            return f"{self.path.name} could not be completed and there is no CSV to rebuild it from: kept as {kept.name}"
        self.path.unlink(missing_ok=True)     # its space is what the rebuilt file needs
        # Binary columns are hexadecimal text in the CSV: read as text, then decoded
        opts = pc.ConvertOptions(column_types={f.name: pa.string() if pa.types.is_binary(f.type) else f.type
                                               for f in schema}, strings_can_be_null=False,
                                 quoted_strings_can_be_null=False)
        table = _hex_decoded(pc.read_csv(str(csv.path), convert_options=opts), schema)
        tmp = self.path.with_name(f".{self.path.name}.tmp")
        try:
            pq.write_table(table, str(tmp), **writer_options(schema))
        except OSError:
            tmp.unlink(missing_ok=True)
            raise
        os.replace(tmp, self.path)
        self.broken = False
        return f"{self.path.name} rebuilt from {csv.path.name} after a failed write ({table.num_rows} rows)"

    def files(self):
        return [self.path]


def _write_group(writer, blocks: list) -> None:
    """``blocks`` (if any) as one row group."""
    if blocks:
        table = blocks[0] if len(blocks) == 1 else pa.concat_tables(blocks)
        writer.write_table(table, row_group_size=table.num_rows)


def writer_options(schema: pa.Schema) -> dict:
    """How results.parquet's columns are encoded (the values read back the same whatever is chosen here)."""
    floating = [f.name for f in schema if pa.types.is_floating(f.type)]
    return dict(
        # column statistics for thousands of columns times many row groups would make the footer, which the
        # writer keeps in memory until close, the largest thing in a long wide run
        write_statistics=len(schema) <= 257,
        # no dictionary for floating-point columns: a simulation's doubles rarely repeat, so the writer built a
        # dictionary for each column chunk only to give it up (twice the time, and a larger file); integers,
        # Booleans and strings keep theirs
        use_dictionary=[f.name for f in schema if not pa.types.is_floating(f.type)],
        # floating-point values stored byte plane by byte plane (Parquet's BYTE_STREAM_SPLIT): the sign and
        # exponent bytes of a column that moves smoothly are nearly constant, so snappy finds runs it did not find
        # in whole doubles. The 120-double bench table (bench/bench_recording.py): 149 -> 113 MB and ~0.55 ->
        # ~0.35 s CPU (less to compress, and compressible input is compressed faster). The encoding is Parquet
        # format 2.8's (2019): Arrow (pyarrow, pandas) reads it, as do DuckDB since 0.10 and parquet-java; a reader
        # without it (DuckDB before 0.10, Spark's vectorized reader in 2026) cannot read these columns
        use_byte_stream_split=floating,
    )


def _hex_decoded(table: pa.Table, schema: pa.Schema) -> pa.Table:
    """The table with its Binary columns (hexadecimal text in the CSV) turned back into bytes."""
    for k, f in enumerate(schema):
        if pa.types.is_binary(f.type):
            values = [bytes.fromhex(x) for x in table.column(k).to_pylist()]
            table = table.set_column(k, f, pa.array(values, type=pa.binary()))
    return table
