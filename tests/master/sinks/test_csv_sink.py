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
