"""Rows kept in memory only (``sinks: [memory]``) equal the rows the Parquet sink writes, block reuse included; a
DeferredBlock (the memory sink's block, its table built when read) keeps its own rows."""
import pandas as pd
import pyarrow as pa

import master.observers.recording as recording
from master.results import read_results
from master.runner import run
from master.ssp.writer import SspBuilder


def _chain(tmp_path, test_fmus, n=4, stop=0.25, step=1e-3):
    b = SspBuilder("ring", stop=stop, step=step)
    for k in range(n):
        b.add_component(f"I{k}", test_fmus["c2:Integrator"], params={"a": -0.5 * (k + 1), "x0": 1.0 + k})
    for k in range(n):
        b.connect(f"I{k}", "y", f"I{(k + 1) % n}", "u")
    return b.write(tmp_path / "ring.ssp")


def test_memory_rows_equal_the_parquet_rows_across_reused_blocks(tmp_path, test_fmus, monkeypatch):
    ssp = _chain(tmp_path, test_fmus)
    # 40-row blocks: the recording refills the same block six times before the run ends
    monkeypatch.setattr(recording, "BLOCK_BYTES", 8 * 5 * 40)
    run(ssp, output=tmp_path / "disk")
    res = run(ssp, output=None)
    frame = res.frame
    pd.testing.assert_frame_equal(frame, read_results(tmp_path / "disk"), check_exact=True)
    assert len(frame) == 251


def test_a_run_folder_with_memory_rows_writes_no_results_file(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    res = run(ssp, output=tmp_path / "out", sinks=["memory"])
    assert res.metadata["rows_recorded"] == 251
    assert not (tmp_path / "out" / "results.parquet").exists()


def test_deferred_block_keeps_its_own_rows():
    schema = pa.schema([pa.field("time", pa.float64()), pa.field("x", pa.float64()), pa.field("s", pa.string())])
    import numpy as np
    block = np.array([[0.0, 1.5], [1.0, 2.5]])
    d = recording.DeferredBlock(schema, block, [["a"], ["b"]])
    block[:] = -1.0                          # the recording refills its block after a flush
    assert d.num_rows == 2
    assert d.table().equals(pa.table({"time": [0.0, 1.0], "x": [1.5, 2.5], "s": ["a", "b"]}, schema=schema))
