"""A block's table (``block_table``) holds its own copy of the rows, also for a block of one row: the recording
fills the same block again, and a table that was a view of it changed under whoever kept it (the memory sink next
to a file sink, a table read from a running ``Execution``). The expected values come from the FMU itself: py:Types
counts its steps (``counter`` is k in the row of step k)."""
import numpy as np
import pyarrow as pa
import pyarrow.csv as pc
import pytest

from master.execution import Execution
from master.observers import recording
from master.observers.recording import block_table
from master.ssp.writer import SspBuilder

STEPS = 40


@pytest.fixture
def types_ssp(tmp_path, test_fmus):
    b = SspBuilder("types", stop=STEPS * 0.1, step=0.1)
    b.add_component("t", test_fmus["py:Types"])
    return b.write(tmp_path / "types.ssp")


@pytest.fixture
def blocks_of(monkeypatch):
    def set_rows(rows):
        init = recording.Recording.__init__
        monkeypatch.setattr(recording.Recording, "__init__",
                            lambda self, *a, **kw: init(self, *a, **{**kw, "block_rows": rows}))
    return set_rows


@pytest.mark.parametrize("shape", [(1, 5), (7, 1), (1, 1)])
def test_a_block_table_is_not_a_view_of_its_block(shape):
    block = np.arange(float(np.prod(shape))).reshape(shape)
    schema = pa.schema([("time", pa.float64())] + [(f"x{k}", pa.float64()) for k in range(shape[1] - 1)])
    table = block_table(schema, block, [[] for _ in range(shape[0])])
    want = block.copy()
    block[:] = -1.0             # the recording fills its block again
    assert [c.to_numpy().tolist() for c in table.columns] == want.T.tolist()


def test_a_memory_sink_beside_a_file_keeps_every_row_of_one_row_blocks(tmp_path, types_ssp, blocks_of):
    blocks_of(1)
    ex = Execution(types_ssp, output=tmp_path / "out", sinks=["memory", "csv"], record=["t.counter"])
    ex.simulate_until()
    kept = ex.memory_table()
    ex.close()
    assert kept.column("t.counter").to_pylist() == list(range(STEPS + 1))      # (its int32 column is a copy)
    # before: every time read as the last one (4.0, 4.0, ...), each table's a view of the block's one row
    assert np.allclose(kept.column("time").to_numpy(), np.arange(STEPS + 1) * 0.1, rtol=0, atol=1e-12)
    csv = pc.read_csv(tmp_path / "out" / "results.csv")
    assert csv.column("t.counter").to_pylist() == list(range(STEPS + 1))


def test_a_table_read_from_a_running_execution_stays_as_it_was_read(types_ssp, blocks_of):
    blocks_of(16)
    ex = Execution(types_ssp, record=["t.counter"])
    ex.simulate_until(16 * 0.1)         # rows 0..16: one block written, one row in the next
    early = ex.memory_table()
    assert ex.recording.fill == 1
    ex.simulate_until()                 # that row's place in the block is filled again (rows 32..)
    ex.close()
    assert early.column("t.counter").to_pylist() == list(range(17))
    # before: the last row's time was a view of the block, read later as row 32's (3.2)
    assert np.allclose(early.column("time").to_numpy(), np.arange(17) * 0.1, rtol=0, atol=1e-12)
    assert ex.memory_table().column("t.counter").to_pylist() == list(range(STEPS + 1))
