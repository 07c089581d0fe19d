"""results.csv's text: the format written out by hand for values whose repr Python documents (shortest round-trip
digits, exponent notation below 1e-4 and from 1e16), for every numeric column type, with the C formatter and
with the Python reference (``COSIM_MASTER_PURE_PYTHON=1``); and the text read back to the same doubles."""
import struct

import numpy as np
import pyarrow as pa
import pyarrow.csv as pc
import pytest

from master import accel
from master.sinks.csv import CsvSink
from master.sinks.csv_native import formatter

# (value, the text Python's repr gives it, written out by hand)
DOUBLES = [(0.0, "0.0"), (-0.0, "-0.0"), (1.0, "1.0"), (-2.5, "-2.5"), (0.1, "0.1"),
           (0.1 + 0.2, "0.30000000000000004"), (293.15, "293.15"), (1e-4, "0.0001"), (1e-5, "1e-05"),
           (1.5e-7, "1.5e-07"), (1e15, "1000000000000000.0"), (1e16, "1e+16"),
           (123456789012345680.0, "1.2345678901234568e+17"),
           (1234567890123456.8, "1234567890123456.8"), (2.0 ** 53, "9007199254740992.0"), (1e22, "1e+22"),
           (1e23, "1e+23"), (5e-324, "5e-324"), (2.2250738585072014e-308, "2.2250738585072014e-308"),
           (1.7976931348623157e308, "1.7976931348623157e+308"), (float("inf"), "inf"), (float("-inf"), "-inf"),
           (float("nan"), "nan"), (struct.unpack("<d", struct.pack("<Q", 0xFFF8000000000001))[0], "nan"),
           (9.999999999999999e-5, "9.999999999999999e-05"), (0.001, "0.001"), (100.0, "100.0")]


@pytest.fixture(params=["C", "Python"])
def writer(request, monkeypatch):
    if request.param == "C":
        if formatter() is None:
            pytest.skip("the C formatter cannot be built here")
    else:
        monkeypatch.setenv(accel.ENV, "1")
        assert formatter() is None
    return request.param


def _written(tmp_path, table) -> str:
    sink = CsvSink()
    sink.open(tmp_path, table.schema)
    sink.write(table)
    sink.close()
    return (tmp_path / "results.csv").read_text()


def test_doubles_are_written_as_python_writes_them(tmp_path, writer):
    values = [v for v, _ in DOUBLES]
    table = pa.table({"time": pa.array(np.arange(len(values), dtype=float)), "m.x": pa.array(values)})
    lines = _written(tmp_path, table).splitlines()
    assert lines[0] == "time,m.x"
    assert lines[1:] == [f"{float(k)!r},{text}" for k, (_, text) in enumerate(DOUBLES)]


def test_repeated_values_and_their_neighbours(tmp_path, writer):
    # a value equal to the one above is copied from it: one that only looks alike (-0.0, another NaN) is not
    values = [293.15, 293.15, 293.15, 1e-5, 1e-5, 0.0, -0.0, -0.0, 0.0, float("nan"), float("-nan"), 1e16, 1e16,
              0.1, 0.1 + 0.2, 0.1 + 0.2]
    table = pa.table({"x": pa.array(values), "c": pa.array([2.5] * len(values)),
                      "f": pa.array([0.1] * 3 + [0.2] * (len(values) - 3), pa.float32())})
    lines = _written(tmp_path, table).splitlines()[1:]
    assert [line.split(",")[0] for line in lines] == [
        "293.15", "293.15", "293.15", "1e-05", "1e-05", "0.0", "-0.0", "-0.0", "0.0", "nan", "nan", "1e+16",
        "1e+16", "0.1", "0.30000000000000004", "0.30000000000000004"]
    assert {line.split(",")[1] for line in lines} == {"2.5"}
    assert [line.split(",")[2] for line in lines] == ["0.10000000149011612"] * 3 + ["0.20000000298023224"] * 13


def test_integers_booleans_and_float32_columns(tmp_path, writer):
    table = pa.table({"i8": pa.array([-128, 127, 0], pa.int8()), "u8": pa.array([0, 255, 7], pa.uint8()),
                      "i16": pa.array([-32768, 32767, -1], pa.int16()), "u16": pa.array([65535, 0, 1], pa.uint16()),
                      "i32": pa.array([-2**31, 2**31 - 1, 42], pa.int32()),
                      "u32": pa.array([2**32 - 1, 0, 3], pa.uint32()),
                      "i64": pa.array([-2**63, 2**63 - 1, 0], pa.int64()),
                      "u64": pa.array([2**64 - 1, 0, 2**53 + 1], pa.uint64()),
                      "b": pa.array([True, False, True]), "f32": pa.array([0.1, 1e-5, 3.0], pa.float32())})
    assert _written(tmp_path, table).splitlines()[1:] == [
        "-128,0,-32768,65535,-2147483648,4294967295,-9223372036854775808,18446744073709551615,true,"
        "0.10000000149011612",
        "127,255,32767,0,2147483647,0,9223372036854775807,0,false,9.999999747378752e-06",
        "0,7,-1,1,42,3,0,9007199254740993,true,3.0"]


def test_a_table_with_strings_is_written_whole(tmp_path, writer):
    # String and Binary columns are the reference's alone: the C formatter leaves such a table to it
    table = pa.table({"time": [0.0, 0.5], "s": pa.array(['a,"b"', "c"]), "x": pa.array([1e-5, 2.0]),
                      "bin": pa.array([b"\x00\xff", b""], pa.binary())})
    assert _written(tmp_path, table).splitlines() == ["time,s,x,bin", '0.0,"a,""b""",1e-05,00ff', '0.5,c,2.0,']


def test_many_rows_in_chunks_read_back_bit_for_bit(tmp_path, writer, monkeypatch):
    import master.sinks.csv_native as native
    monkeypatch.setattr(native, "CHUNK_CELLS", 1000)      # many chunks of the reused buffer
    rng = np.random.default_rng(5)
    cols = {"time": np.arange(3001) * 1e-4}
    for k in range(7):
        cols[f"c{k}"] = rng.standard_normal(3001) * 10.0 ** rng.integers(-30, 30, 3001)
    table = pa.table(cols)
    _written(tmp_path, table)
    back = pc.read_csv(tmp_path / "results.csv", convert_options=pc.ConvertOptions(
        column_types={f.name: f.type for f in table.schema}))
    for name in cols:
        assert back.column(name).to_numpy().view(np.uint64).tolist() == cols[name].view(np.uint64).tolist()


# the longest text of each of repr's layouts: exponent with 17 digits, 0.000<17 digits>, <16 digits>.0, the point
# after 16 of 17 digits; each negative too
LAYOUTS = [-1.2345678901234567e-300, -0.00012345678901234567, -1234567890123456.0, -1234567890123456.8,
           -1e+300, -0.0001, -1e+15]


@pytest.mark.parametrize("ncols", [1, 2, 5])
def test_the_formatter_writes_nothing_past_its_room(ncols):
    """The C formatter moves a double's text with fixed-size copies that write past the text (the next cell
    overwrites them): they must stay inside rows * (CELL_BYTES * columns + 1) + ROOM_BYTES, which is what the
    sink gives it. Bytes past that are filled with a mark that must survive, for every layout in the last cell."""
    import master.sinks.csv_native as native
    lib = formatter()
    if lib is None:
        pytest.skip("the C formatter cannot be built here")

    class Guarded(native.Scratch):
        def get(self, size):
            self.size = size
            self.whole = np.full(size + 256, 0xA5, dtype=np.uint8)
            return self.whole[:size]

    for last in LAYOUTS:
        values = [LAYOUTS[(k + 3) % len(LAYOUTS)] for k in range(ncols - 1)] + [last]
        table = pa.table({f"c{k}": pa.array([v], pa.float64()) for k, v in enumerate(values)})
        scratch = Guarded()
        text = b"".join(bytes(c) for c in native.rows_in_chunks(lib, table, scratch))
        assert text.decode() == ",".join(repr(v) for v in values) + "\n"
        assert scratch.size == ncols * native.CELL_BYTES + 1 + native.ROOM_BYTES
        assert (scratch.whole[scratch.size:] == 0xA5).all(), last


def test_blocks_written_one_after_another_through_the_kept_buffer(tmp_path, writer):
    """The sink keeps its output buffer from block to block: a block of short texts after one of long texts must
    not carry any of the earlier bytes."""
    long = pa.table({"a": pa.array([-1.2345678901234567e-300] * 50), "b": pa.array([1234567890123456.8] * 50)})
    short = pa.table({"a": pa.array([1.0, 2.5, 0.0]), "b": pa.array([3.0, -0.0, 1e-05])})
    sink = CsvSink()
    sink.open(tmp_path, long.schema)
    sink.write(long)
    sink.write(short)
    sink.write(long.slice(0, 2))
    sink.close()
    lines = (tmp_path / "results.csv").read_text().splitlines()
    assert lines[0] == "a,b"
    long_line = f"{-1.2345678901234567e-300!r},{1234567890123456.8!r}"
    assert long_line == "-1.2345678901234568e-300,1234567890123456.8"
    assert lines[1:] == [long_line] * 50 + ["1.0,3.0", "2.5,-0.0", "0.0,1e-05"] + [long_line] * 2
