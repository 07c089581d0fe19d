"""The recording's memory bound: blocks (and so Parquet row groups) sized from a byte budget, the CSV written a
slice of rows at a time, and ``read_results`` filling one array per type -- with the results unchanged."""
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import master.observers.recording as recording
import master.sinks.parquet as parquet
from master.observers.recording import BLOCK_BYTES, MAX_BLOCK_ROWS, MIN_BLOCK_ROWS, block_rows_for
from master.results import read_parquet_frame, read_results
from master.runner import run
from master.ssp.writer import SspBuilder
from master.supervise import run_supervised


def test_block_rows_from_the_byte_budget():
    # 16 MiB of 8-byte cells: 2,097,152 cells; a 256-UAV fleet's 5700 columns -> 367 rows (2097152 // 5700)
    assert BLOCK_BYTES == 16 * 2**20
    assert block_rows_for(5700) == 367
    assert block_rows_for(5700) * 5700 * 8 <= BLOCK_BYTES < (block_rows_for(5700) + 1) * 5700 * 8
    assert block_rows_for(3) == MAX_BLOCK_ROWS == 4096         # narrow tables keep long row groups
    assert block_rows_for(10**7) == MIN_BLOCK_ROWS             # never fewer rows than that
    assert block_rows_for(10, budget=8 * 10 * 7) == 16         # the floor wins over a tiny budget
    assert block_rows_for(10, budget=8 * 10 * 100) == 100


def _chain(tmp_path, test_fmus, n=6, stop=0.25, step=1e-3):
    """n integrators in a ring: n + 1 recorded columns (time and every y), 251 rows."""
    b = SspBuilder("ring", stop=stop, step=step)
    for k in range(n):
        b.add_component(f"I{k}", test_fmus["c2:Integrator"], params={"a": -0.5 * (k + 1), "x0": 1.0 + k})
    for k in range(n):
        b.connect(f"I{k}", "y", f"I{(k + 1) % n}", "u")
    return b.write(tmp_path / "ring.ssp")


@pytest.mark.parametrize("supervised", [False, True])
def test_row_groups_within_the_budget_and_results_unchanged(tmp_path, test_fmus, monkeypatch, supervised):
    ssp = _chain(tmp_path, test_fmus)
    go = run_supervised if supervised else run
    go(ssp, output=tmp_path / "default")
    cols = pq.read_schema(tmp_path / "default" / "results.parquet").names
    assert len(cols) == 7
    budget = 8 * len(cols) * 40            # 40 rows of 7 doubles
    monkeypatch.setattr(recording, "BLOCK_BYTES", budget)
    monkeypatch.setattr(parquet, "ROW_GROUP_BYTES", budget)     # the Parquet sink's row groups: the same budget
    go(ssp, output=tmp_path / "small")
    meta = pq.ParquetFile(tmp_path / "small" / "results.parquet").metadata
    sizes = [meta.row_group(g).num_rows for g in range(meta.num_row_groups)]
    # 251 rows in blocks of 40: six full ones and the 11 rows left at the end
    assert sizes == [40] * 6 + [11]
    assert all(8 * len(cols) * r <= budget for r in sizes)
    assert pq.ParquetFile(tmp_path / "default" / "results.parquet").metadata.num_row_groups == 1
    a, b = read_results(tmp_path / "default"), read_results(tmp_path / "small")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert len(a) == 251
    assert (tmp_path / "default" / "results.csv").read_bytes() == (tmp_path / "small" / "results.csv").read_bytes()


@pytest.mark.parametrize("formatter", ["C", "Python"])
def test_csv_written_in_slices_equals_the_parquet(tmp_path, test_fmus, monkeypatch, formatter):
    import master.sinks.csv as csv_sink
    import master.sinks.csv_native as csv_native
    if formatter == "Python":        # the reference writes the rows (CSV_CELLS), else C (CHUNK_CELLS)
        monkeypatch.setenv("COSIM_MASTER_PURE_PYTHON", "1")
    monkeypatch.setattr(csv_sink, "CSV_CELLS", 5)      # under a row of 7 cells: one row per slice
    monkeypatch.setattr(csv_native, "CHUNK_CELLS", 5)
    out = tmp_path / "out"
    run(_chain(tmp_path, test_fmus), output=out)
    df = read_results(out)
    text = (out / "results.csv").read_text().splitlines()
    assert text[0] == ",".join(df.columns)
    assert len(text) == 1 + len(df)
    for line, row in zip(text[1:], df.itertuples(index=False)):
        assert line == ",".join(repr(float(x)) for x in row)


def _mixed_table(n=1000):
    rng = np.random.default_rng(7)
    return pa.table({
        "time": np.arange(n) * 0.1, "a.x": rng.standard_normal(n),
        "b.i": pa.array(rng.integers(-5, 5, n).astype(np.int32)),
        "c.s": pa.array([f"s{k}" for k in range(n)]),
        "d.b": pa.array(rng.integers(0, 2, n).astype(bool)),
        "e.u": pa.array(rng.integers(0, 2**62, n, dtype=np.uint64) + np.uint64(2**63)),
        "f.i8": pa.array(rng.integers(-100, 100, n).astype(np.int8)),
        "g.bin": pa.array([bytes([k % 256]) for k in range(n)], type=pa.binary())})


@pytest.mark.parametrize("row_group", [1000, 128, 7])
@pytest.mark.parametrize("columns", [None, ["d.b", "time", "c.s"], ["e.u"], ["a.x"]])
def test_read_results_equals_pandas_reader(tmp_path, row_group, columns):
    path = tmp_path / "results.parquet"
    pq.write_table(_mixed_table(), path, row_group_size=row_group)
    want = pd.read_parquet(path, columns=columns)           # pandas' own reader is the reference
    got = read_parquet_frame(path, columns)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    assert list(got.dtypes) == list(want.dtypes) and got.columns.equals(want.columns)
    got.iloc[0, 0] = got.iloc[0, 0]                          # a frame of its own, writable


def test_read_results_with_nulls_as_pandas_does(tmp_path):
    path = tmp_path / "results.parquet"
    t = pa.table({"time": [0.0, 1.0, 2.0], "x.i": pa.array([1, None, 3], type=pa.int32())})
    pq.write_table(t, path, row_group_size=2)
    pd.testing.assert_frame_equal(read_parquet_frame(path), pd.read_parquet(path), check_exact=True)
    assert read_parquet_frame(path)["x.i"].isna().sum() == 1
