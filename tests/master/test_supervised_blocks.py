"""A supervised run's record blocks reach the parent's files whole: the child fills the shared block, says how many
rows it holds, and fills it again once the parent has copied them out (supervise._PipeSink). With blocks of a few
rows the block is refilled many times over, so a copy taken after the child went on (or none) would show as
rows of a later block. The expected values come from the FMU itself: py:Types counts its steps (``counter`` is k
in the row of step k), adds 1 to its Integer input (0), negates its Boolean input (False), appends "!" to its
String input ("hello") and doubles its Real input (0.0); the CSV is the Python reference's text of those rows."""
import numpy as np
import pyarrow.parquet as pq
import pytest

import master
from master.sinks.csv_text import format_rows
from master.ssp.writer import SspBuilder
from master.supervise import run_supervised

STEPS = 60


def _types(tmp_path, test_fmus):
    b = SspBuilder("types", stop=STEPS * 0.1, step=0.1)
    b.add_component("t", test_fmus["py:Types"])
    return b.write(tmp_path / "types.ssp")


@pytest.mark.parametrize("block_rows", [1, 7, 16])
def test_every_row_of_many_blocks_reaches_the_files(tmp_path, test_fmus, monkeypatch, block_rows):
    from master.observers import recording
    init = recording.Recording.__init__
    # the child is a fork of this process: its recording takes the small blocks too
    monkeypatch.setattr(recording.Recording, "__init__",
                        lambda self, *a, **kw: init(self, *a, **{**kw, "block_rows": block_rows}))
    ssp = _types(tmp_path, test_fmus)
    sup = run_supervised(ssp, output=tmp_path / "sup", record=["t.*"])
    assert sup.metadata["rows_recorded"] == STEPS + 1
    table = pq.read_table(tmp_path / "sup" / "results.parquet")
    assert table.column("t.counter").to_pylist() == list(range(STEPS + 1))
    assert np.allclose(table.column("time").to_numpy(), np.arange(STEPS + 1) * 0.1, rtol=0, atol=1e-12)
    assert set(table.column("t.i_out").to_pylist()) == {1}
    assert set(table.column("t.b_out").to_pylist()) == {True}
    assert set(table.column("t.s_out").to_pylist()) == {"hello!"}
    assert set(table.column("t.r_out").to_pylist()) == {0.0}
    # the whole table as an unsupervised run records it, and the CSV as the reference writes those rows
    plain = master.run(ssp, output=tmp_path / "plain", record=["t.*"])
    assert table.equals(pq.read_table(tmp_path / "plain" / "results.parquet"))
    assert plain.metadata["rows_recorded"] == STEPS + 1
    csv = (tmp_path / "sup" / "results.csv").read_bytes()
    header, rows = csv.split(b"\n", 1)
    assert header.decode().split(",") == table.schema.names
    assert rows == format_rows(table).encode()
