"""The compiled step's inputs unpacked by struct (compiled._unpacker): at any sorted set of positions, the same
objects ``buf.tolist()`` has there -- same type, same value, a float with the same bits (NaN payloads and -0.0
included) -- for every buffer type it takes; the others keep ``tolist``. And the step source indexes the unpacked
tuple by the order of the positions."""
import random
import struct
import zlib

import numpy as np
import pytest

from master.algorithms import compiled

DTYPES = [np.float64, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64]


def _bits(v):
    return struct.pack("<d", v) if isinstance(v, float) else v


def _random_buffer(rng, dtype, n):
    if dtype is np.float64:
        bits = [rng.getrandbits(64) for _ in range(n)]      # any double: NaNs, infinities, subnormals, -0.0
        return np.array(bits, dtype=np.uint64).view(np.float64)
    info = np.iinfo(dtype)
    return np.array([rng.randint(int(info.min), int(info.max)) for _ in range(n)], dtype=dtype)


@pytest.mark.parametrize("dtype", DTYPES)
def test_unpacked_values_are_tolists(dtype):
    rng = random.Random(zlib.crc32(np.dtype(dtype).str.encode()))     # hash(str) differs per process
    for _ in range(400):
        n = rng.randrange(1, 120)
        buf = _random_buffer(rng, dtype, n)
        positions = sorted(rng.sample(range(n), rng.randrange(1, n + 1)))
        unpack, mem = compiled._unpacker(buf, positions)
        got = unpack(mem)
        want = [buf.tolist()[p] for p in positions]
        assert [type(v) for v in got] == [type(v) for v in want]
        assert [_bits(v) for v in got] == [_bits(v) for v in want]
        buf[positions[-1]] = buf[positions[0]]      # the memory is read at each call, not copied at binding
        assert _bits(unpack(mem)[-1]) == _bits(buf.tolist()[positions[0]])


def test_other_buffers_keep_tolist():
    assert compiled._unpacker(np.zeros(4, dtype=np.float32), [1]) is None
    assert compiled._unpacker(np.zeros(4, dtype=bool), [1]) is None
    assert compiled._unpacker(np.zeros(8)[::2], [1]) is None          # not contiguous
    assert compiled._unpacker(np.zeros(4), []) is None


def test_source_indexes_the_tuple_in_position_order():
    blocks = [["S1['a'] = VReal[21]", "S1['b'] = VReal[3]", "S1['c'] = VInteger[2]"], ["S2['d'] = VReal[40]"]]
    renum = compiled._renumbered(blocks, "Real", {3: 0, 21: 1, 40: 2})
    assert renum == [["S1['a'] = VReal[1]", "S1['b'] = VReal[0]", "S1['c'] = VInteger[2]"], ["S2['d'] = VReal[2]"]]
