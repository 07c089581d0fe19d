"""results.parquet: doubles stored without a dictionary (they rarely repeat: the writer built one per column chunk
only to give it up), integers, Booleans and strings with one; every value reads back."""
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from master.sinks.parquet import ParquetSink


def test_dictionaries_for_all_but_floating_point_columns(tmp_path):
    rng = np.random.default_rng(3)
    table = pa.table({"time": np.arange(500) * 0.1, "m.x": rng.standard_normal(500),
                      "m.f": pa.array(rng.standard_normal(500), pa.float32()),
                      "m.n": pa.array(rng.integers(0, 3, 500), pa.int32()),
                      "m.s": pa.array(["on", "off"] * 250), "m.b": pa.array([True, False] * 250)})
    sink = ParquetSink()
    sink.open(tmp_path, table.schema)
    sink.write(table.slice(0, 300))
    sink.write(table.slice(300))
    sink.close()
    meta = pq.ParquetFile(tmp_path / "results.parquet").metadata
    for g in range(meta.num_row_groups):
        encodings = {meta.row_group(g).column(c).path_in_schema: meta.row_group(g).column(c).encodings
                     for c in range(meta.num_columns)}
        for name in ("time", "m.x", "m.f"):
            assert not any("DICTIONARY" in e for e in encodings[name]), (name, encodings[name])
        for name in ("m.n", "m.s"):
            assert any("DICTIONARY" in e for e in encodings[name]), (name, encodings[name])
    assert pq.read_table(tmp_path / "results.parquet").equals(table)
