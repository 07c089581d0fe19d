"""master.arrow_numpy against pyarrow's own conversions (the peer it stands in for), bit for bit (that a run then
imports no pandas: tests/master/test_run_imports.py)."""
import numpy as np
import pyarrow as pa
import pytest

from master.arrow_numpy import from_numpy, from_objects, to_numpy

SPECIAL = [0.0, -0.0, 1.5, -2.25, 1e308, 5e-324, float("inf"), float("-inf"), 0.1, 1 / 3]
FIXED = [pa.int8(), pa.uint8(), pa.int16(), pa.uint16(), pa.int32(), pa.uint32(), pa.int64(), pa.uint64()]


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def test_doubles_keep_every_bit_including_nan_payloads_and_negative_zero():
    values = np.array(SPECIAL + [float("nan")])
    values = np.append(values, np.frombuffer(np.uint64(0x7FF8_0000_0000_0001).tobytes(), dtype=np.float64))
    arr = from_numpy(values)
    assert arr.type == pa.float64() and arr.null_count == 0
    assert arr.slice(0, len(SPECIAL)).equals(pa.array(values[:len(SPECIAL)]))     # equals() fails on NaN: bits below
    assert _same_bits(np.frombuffer(arr.buffers()[1], dtype=np.float64)[:len(values)], values)
    assert _same_bits(to_numpy(arr), values)


@pytest.mark.parametrize("typ", FIXED)
def test_integers_of_every_width_round_trip_at_their_limits(typ):
    info = np.iinfo(np.dtype(typ.to_pandas_dtype()))
    values = np.array([info.min, info.min + 1, 0, 1, info.max - 1, info.max], dtype=info.dtype)
    arr = from_numpy(values, typ)
    assert arr.equals(pa.array(values, type=typ))
    assert _same_bits(to_numpy(arr), values)


def test_strided_columns_of_a_block_are_copied_and_contiguous_ones_shared_as_pyarrow_does():
    block = np.arange(12.0).reshape(4, 3)
    col = from_numpy(block[:, 1])
    assert col.to_pylist() == [1.0, 4.0, 7.0, 10.0]
    block[0, 1] = 99.0
    assert col.to_pylist()[0] == 1.0                   # a copy: the recording reuses its block
    flat = np.arange(3.0)
    shared, theirs = from_numpy(flat), pa.array(flat)
    flat[0] = 42.0
    assert shared.to_pylist()[0] == theirs.to_pylist()[0] == 42.0


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 17])
def test_booleans_are_packed_and_unpacked_at_any_length_and_offset(n):
    rng = np.random.default_rng(n)
    values = rng.random(n) < 0.5
    arr = from_numpy(values)
    assert arr.equals(pa.array(values))
    assert _same_bits(to_numpy(arr), values)
    for start in range(min(n, 9)):
        assert _same_bits(to_numpy(arr.slice(start)), values[start:])


def test_slices_and_chunked_columns_read_back_as_pyarrow_reads_them():
    a = from_numpy(np.arange(10, dtype=np.int32), pa.int32())
    chunked = pa.chunked_array([a.slice(3, 4), a.slice(0, 2), a.slice(9)])
    assert to_numpy(chunked).tolist() == [3, 4, 5, 6, 0, 1, 9]
    assert to_numpy(pa.chunked_array([], type=pa.float64())).dtype == np.float64
    assert to_numpy(a.slice(5, 0)).shape == (0,)


def test_strings_and_binaries_build_the_arrays_pyarrow_builds():
    strings = ["", "a", "ä€😀", 'quote " and, comma', "\n"]
    arr = from_objects(strings, pa.string())
    arr.validate(full=True)
    assert arr.equals(pa.array(strings, type=pa.string()))
    assert list(to_numpy(arr)) == strings
    blobs = [b"", b"\x00\xff", bytes(range(256))]
    arr = from_objects(blobs, pa.binary())
    arr.validate(full=True)
    assert arr.equals(pa.array(blobs, type=pa.binary()))
    assert to_numpy(arr.slice(1)).tolist() == blobs[1:]


def test_values_it_does_not_cover_are_left_to_pyarrow():
    assert from_objects(["a", None], pa.string()).to_pylist() == ["a", None]      # a null
    with_null = pa.array([1.0, None])
    assert np.isnan(to_numpy(with_null)[1])
