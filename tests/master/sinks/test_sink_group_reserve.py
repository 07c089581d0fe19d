"""The 4 MB reserve that SinkGroup holds while a run records (room to close the files on a full disk) never makes
a run fail that would fit without it: on a disk with a little more than the reserve free, the reserve took the
room that opening the result files needs, and the run ended as "disk full" before its first row."""
import errno
import os
import subprocess

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from master.errors import CosimError
from master.sinks.base import Sink
from master.sinks.csv import CsvSink
from master.sinks.group import RESERVE_BYTES, RESERVE_NAME, SinkGroup
from master.sinks.parquet import ParquetSink


class OnADisk(Sink):
    """A file sink on a disk that has room for its first bytes only while the reserve is not there (``room``
    False: no room at all); keeps the rows it is given."""

    def __init__(self, room=True):
        self.room, self.rows = room, []

    def open(self, out_dir, schema):
        super().open(out_dir, schema)
        self.path = out_dir / "rows.txt"
        if not self.room or (out_dir / RESERVE_NAME).exists():
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path))
        self.path.write_text("header\n")

    def write(self, block):
        self.rows += block.column(0).to_pylist()

    def files(self):
        return [self.path]


SCHEMA = pa.schema([("time", pa.float64())])


def test_a_reserve_that_takes_the_last_room_is_given_back_and_the_files_open(tmp_path):
    sink = OnADisk()
    group = SinkGroup([sink], tmp_path)
    group.open(SCHEMA)          # before: CosimError "results: disk full while writing .../rows.txt"
    assert group.open_sinks == [sink] and not (tmp_path / RESERVE_NAME).exists()
    group.write(pa.table({"time": [0.0, 0.5]}))
    group.close()
    assert sink.rows == [0.0, 0.5] and group.rows == 2 and group.failure is None
    assert sink.path.read_text() == "header\n"


def test_no_room_at_all_is_still_one_line_and_leaves_nothing(tmp_path):
    sink = OnADisk(room=False)
    group = SinkGroup([sink], tmp_path)
    with pytest.raises(CosimError, match=r"results: disk full while writing .*rows\.txt$"):
        group.open(SCHEMA)
    assert group.open_sinks == [] and sorted(os.listdir(tmp_path)) == []


@pytest.fixture
def disk_with_room_for_the_reserve_and_one_page(tmp_path):
    """A tmpfs whose free space is the reserve and one page more (needs root to mount)."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={RESERVE_BYTES + (64 << 10)}", "tmpfs", str(mnt)],
                       capture_output=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (needs root): " + r.stderr.decode().strip())
    try:
        page = os.statvfs(mnt).f_frsize
        out = mnt / "out"
        out.mkdir()
        st = os.statvfs(mnt)
        with open(mnt / "filler", "wb") as fh:
            fh.write(b"\0" * (st.f_bavail * st.f_frsize - RESERVE_BYTES - page))
        st = os.statvfs(mnt)
        assert st.f_bavail * st.f_frsize == RESERVE_BYTES + page
        yield out
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_csv_and_parquet_open_on_a_disk_with_the_reserve_and_a_page_free(disk_with_room_for_the_reserve_and_one_page):
    out = disk_with_room_for_the_reserve_and_one_page
    schema = pa.schema([("time", pa.float64()), ("x", pa.float64())])
    t = np.arange(50) * 0.1
    table = pa.table({"time": t, "x": np.cos(t)}, schema=schema)
    group = SinkGroup([ParquetSink(), CsvSink()], out)
    group.open(schema)          # before: the CSV's header took the page, and the Parquet file could not open
    group.write(table)
    group.close()
    assert group.failure is None and group.rows == 50
    assert pq.read_table(out / "results.parquet").equals(table)
    lines = (out / "results.csv").read_text().splitlines()
    assert lines == ["time,x"] + [f"{a!r},{b!r}" for a, b in zip(t.tolist(), np.cos(t).tolist())]
    assert not (out / RESERVE_NAME).exists()
