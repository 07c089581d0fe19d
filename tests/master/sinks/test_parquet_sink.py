"""results.parquet: doubles stored without a dictionary (they rarely repeat: the writer built one per column chunk
only to give it up) and byte plane by byte plane (BYTE_STREAM_SPLIT, which lets snappy find the runs in the sign
and exponent bytes); integers, Booleans and strings with a dictionary; every value reads back bit for bit."""
import math

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from master.sinks import parquet
from master.sinks.parquet import ParquetSink


def _encodings(path):
    meta = pq.ParquetFile(path).metadata
    return [{meta.row_group(g).column(c).path_in_schema: meta.row_group(g).column(c).encodings
             for c in range(meta.num_columns)} for g in range(meta.num_row_groups)]


def _written(tmp_path, table, cut):
    sink = ParquetSink()
    sink.open(tmp_path, table.schema)
    sink.write(table.slice(0, cut))
    sink.write(table.slice(cut))
    sink.close()
    return tmp_path / "results.parquet"


def test_encodings_by_column_type(tmp_path, monkeypatch):
    monkeypatch.setattr(parquet, "ROW_GROUP_BYTES", 1)        # a row group per block: the encodings of each
    rng = np.random.default_rng(3)
    table = pa.table({"time": np.arange(500) * 0.1, "m.x": rng.standard_normal(500),
                      "m.f": pa.array(rng.standard_normal(500), pa.float32()),
                      "m.n": pa.array(rng.integers(0, 3, 500), pa.int32()),
                      "m.s": pa.array(["on", "off"] * 250), "m.b": pa.array([True, False] * 250)})
    path = _written(tmp_path, table, 300)
    groups = _encodings(path)
    assert len(groups) == 2
    for encodings in groups:
        for name in ("time", "m.x", "m.f"):
            assert not any("DICTIONARY" in e for e in encodings[name]), (name, encodings[name])
            assert "BYTE_STREAM_SPLIT" in encodings[name], (name, encodings[name])
        for name in ("m.n", "m.s"):
            assert any("DICTIONARY" in e for e in encodings[name]), (name, encodings[name])
            assert "BYTE_STREAM_SPLIT" not in encodings[name], (name, encodings[name])
    back = pq.read_table(path)
    assert back.equals(table) and back.schema.equals(table.schema, check_metadata=True)


def test_doubles_read_back_bit_for_bit(tmp_path):
    """The awkward doubles (both zeros, NaNs of other payloads and signs, infinities, subnormals, the last bit of
    a mantissa) and smooth ones, as the byte planes split and join them."""
    awkward = [0.0, -0.0, math.inf, -math.inf, 5e-324, -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
               0.1, 0.30000000000000004, 293.15, np.nextafter(293.15, 300.0)]
    nans = np.array([0x7FF8000000000000, 0xFFF8000000000000, 0x7FF0000000000001, 0x7FF4000000000123],
                    dtype=np.uint64).view(np.float64)
    x = np.concatenate([awkward, nans, 293.15 + np.sin(np.arange(3000) * 1e-3)])
    f32 = np.concatenate([np.array([0.0, -0.0, 1e-45, 3.4e38], np.float32),
                          np.linspace(-1, 1, len(x) - 4, dtype=np.float32)])
    table = pa.table({"time": np.arange(len(x)) * 1e-4, "m.x": x, "m.f": pa.array(f32, pa.float32())})
    back = pq.read_table(_written(tmp_path, table, 7))
    for name in table.column_names:
        want = table.column(name).to_numpy()
        got = back.column(name).to_numpy()
        assert got.dtype == want.dtype
        assert got.view(f"u{want.itemsize}").tobytes() == want.view(f"u{want.itemsize}").tobytes(), name


def _blocks(n, rows=100):
    """n blocks of ``rows`` rows of two doubles (1600 bytes of cells each at 100 rows), times continuing."""
    return [pa.table({"time": (np.arange(rows) + k * rows) * 0.5, "m.x": np.sin(np.arange(rows) + k * rows)})
            for k in range(n)]


def _row_groups(path):
    meta = pq.ParquetFile(path).metadata
    return [meta.row_group(g).num_rows for g in range(meta.num_row_groups)]


def test_row_groups_gather_blocks_while_one_more_fits_the_budget(tmp_path, monkeypatch):
    blocks = _blocks(10)
    assert blocks[0].nbytes == 1600
    for budget, want in ((5000, [300, 300, 300, 100]),     # 3 x 1600 + 1600 > 5000: a group of three blocks
                         (6400, [400, 400, 200]),           # 4 x 1600 + 1600 > 6400
                         (3199, [100] * 10)):               # a block of half the budget or more: each alone
        monkeypatch.setattr(parquet, "ROW_GROUP_BYTES", budget)
        out = tmp_path / str(budget)
        out.mkdir()
        sink = ParquetSink()
        sink.open(out, blocks[0].schema)
        for b in blocks:
            sink.write(b)
        sink.close()
        assert _row_groups(out / "results.parquet") == want, budget
        assert pq.read_table(out / "results.parquet").equals(pa.concat_tables(blocks))


def test_a_held_block_rolled_back_is_let_go_and_the_file_stays_whole(tmp_path, monkeypatch):
    monkeypatch.setattr(parquet, "ROW_GROUP_BYTES", 5000)
    b = _blocks(4)
    sink = ParquetSink()
    sink.open(tmp_path, b[0].schema)
    sink.write(b[0])
    mark = sink.mark()
    sink.write(b[1])            # held, not in the file yet: another sink's write failed, the group rolls back
    sink.rollback(mark)
    assert not sink.broken
    sink.write(b[2])
    sink.close()
    assert pq.read_table(tmp_path / "results.parquet").equals(pa.concat_tables([b[0], b[2]]))


def test_a_row_group_begun_since_the_mark_cannot_be_rolled_back(tmp_path, monkeypatch):
    monkeypatch.setattr(parquet, "ROW_GROUP_BYTES", 5000)
    b = _blocks(3)
    sink = ParquetSink()
    sink.open(tmp_path, b[0].schema)
    sink.write(b[0])
    sink.write(b[1])
    mark = sink.mark()
    sink.write(b[2])            # the third block begins a row group: in the file
    sink.rollback(mark)
    assert sink.broken          # SinkGroup rebuilds it from the CSV at close (repair)
