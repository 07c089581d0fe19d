"""Sinks written at the same time (``concurrent``: Parquet, the CSV formatted in C) still take each block all or
none: a failure on the helper thread rolls back the sink written here, and the first failure in the sinks' order
is the one reported."""
import errno
import threading

import pyarrow as pa
import pytest

from master.errors import CosimError
from master.sinks.base import Sink
from master.sinks.group import SinkGroup


class Rows(Sink):
    """Keeps the rows it was given; ``fail_at``: the block number whose write raises ``error``."""
    needs_folder = False
    concurrent = True

    def __init__(self, name, fail_at=None, error=None):
        self.name, self.fail_at, self.error = name, fail_at, error
        self.rows, self.blocks, self.threads = [], 0, set()

    def write(self, block):
        self.threads.add(threading.current_thread().name)
        self.blocks += 1
        if self.blocks == self.fail_at:
            self.rows.extend(block.column(0).to_pylist()[:1])      # half-written, as a real failure leaves it
            raise self.error
        self.rows.extend(block.column(0).to_pylist())

    def mark(self):
        return len(self.rows)

    def rollback(self, mark):
        del self.rows[mark:]

    def files(self):
        return []


def _block(start):
    return pa.table({"time": [float(start), float(start + 1)]})


def test_concurrent_sinks_take_every_block_on_two_threads():
    a, b = Rows("a"), Rows("b")
    group = SinkGroup([a, b], None)
    group.open(pa.schema([("time", pa.float64())]))
    for k in range(0, 6, 2):
        group.write(_block(k))
    group.close()
    assert a.rows == b.rows == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0] and group.rows == 6
    assert a.threads == {threading.main_thread().name} and len(b.threads) == 1 and b.threads != a.threads


@pytest.mark.parametrize("failing", ["here", "helper", "both"])
def test_a_failed_block_is_rolled_back_everywhere(failing):
    full = OSError(errno.ENOSPC, "No space left on device")
    a = Rows("a", fail_at=2 if failing in ("here", "both") else None, error=full)
    b = Rows("b", fail_at=2 if failing in ("helper", "both") else None, error=OSError(errno.EIO, "I/O error"))
    group = SinkGroup([a, b], None)
    group.open(pa.schema([("time", pa.float64())]))
    group.write(_block(0))
    with pytest.raises(CosimError) as err:
        group.write(_block(2))
    # the first sink's failure is the one named when both fail; no folder: no rows are written again
    assert ("disk full" if failing != "helper" else "cannot write") in str(err.value)
    assert a.rows == b.rows == [0.0, 1.0] and group.rows == 2
    group.close()


def test_an_error_that_is_no_write_failure_is_raised_as_it_is():
    a, b = Rows("a"), Rows("b", fail_at=1, error=ValueError("a bug"))
    group = SinkGroup([a, b], None)
    group.open(pa.schema([("time", pa.float64())]))
    with pytest.raises(ValueError, match="a bug"):
        group.write(_block(0))
    group.close()
