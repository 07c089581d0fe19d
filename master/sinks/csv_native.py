"""results.csv's rows written by C (``csv_format.c``): the accelerator of ``master.sinks.csv_text.format_rows``.

The reference turns every cell into a Python string (repr of a double costs ~0.6 us in CPython's own dtoa, plus
the string and the join), ~5 MB of CSV a second; a table of 120 doubles over 200,000 rows took 40 s. The C
formatter writes the same bytes (Python's repr of each double: shortest round-trip digits, Ryu's method) at
a few tens of ns a value (a column whose values are another's, an alias variable, copies that column's text),
into one reused buffer, and runs without the GIL (ctypes lets go of it), so the
supervisor's other work goes on meanwhile. It takes tables of numbers and Booleans; a table with a String or
Binary column (a rare, narrow one) keeps the reference. Built on first use by ``master.native_build``;
``COSIM_MASTER_PURE_PYTHON=1`` or no C compiler: the reference writes every row. Declared below as
``CSV_FORMAT`` for the accelerator harness (tests/accelerators/).
"""
from __future__ import annotations

import ctypes
import functools
import math
import struct
from pathlib import Path

import numpy as np
import pyarrow as pa

from .. import accel
from ..arrow_numpy import to_numpy
from ..native_build import compile_cached
from .csv_text import format_rows

SOURCE = Path(__file__).with_name("csv_format.c")
FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared", "-std=gnu11"]
#: the C side's column kinds (csv_format.c), by Arrow type
KINDS = {pa.float64(): 1, pa.float32(): 2, pa.int8(): 3, pa.int16(): 4, pa.int32(): 5, pa.int64(): 6,
         pa.uint8(): 7, pa.uint16(): 8, pa.uint32(): 9, pa.uint64(): 10, pa.bool_(): 11}
CELL_BYTES = 25             # the longest cell ("-2.2250738585072014e-308", a 64-bit integer) and its separator
ROOM_BYTES = 48             # past the last cell: a double's text is moved by fixed-size copies (csv_format.c)
# cells formatted and written at a time: ~1.1 MB of text for doubles, which the write copies into the page cache
# while it is still in the core's cache (chunks of ~4.5 MB cost the kernel's copy 2-4 times the system time)
CHUNK_CELLS = 1 << 16


def _pow5_tables() -> tuple[np.ndarray, np.ndarray]:
    """Ryu's 128-bit powers of five, exact (Python's integers): 5^-i scaled up and rounded up to 125 bits past
    its leading bit, and 5^i scaled to 125 bits, as (low, high) 64-bit halves."""
    inv, pow5 = [], []
    for i in range(342):
        p = 5 ** i
        inv.append((1 << (p.bit_length() - 1 + 125)) // p + 1)
    for i in range(326):
        p = 5 ** i
        shift = p.bit_length() - 125
        pow5.append(p >> shift if shift > 0 else p << -shift)
    mask = (1 << 64) - 1
    halves = lambda vals: np.array([[v & mask, v >> 64] for v in vals], dtype=np.uint64)     # noqa: E731
    return halves(inv), halves(pow5)


@functools.cache
def library():
    """(the loaded C library, None) or (None, why it cannot be built here)."""
    path, why = compile_cached(SOURCE, "csv_format", "csv-format", FLAGS, what="the CSV formatter")
    if path is None:
        return None, why
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as exc:
        return None, f"cannot load {path.name}: {exc}"
    lib.cm_csv_rows.restype = ctypes.c_int64
    lib.cm_csv_rows.argtypes = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int64,
                                ctypes.c_int64, ctypes.c_void_p]
    inv, pow5 = _pow5_tables()
    lib.cm_csv_tables(inv.ctypes.data_as(ctypes.c_void_p), pow5.ctypes.data_as(ctypes.c_void_p))
    return lib, None


def formatter():
    """The C formatter (``rows(table)``: an iterator of byte chunks), or None when it is off or cannot be built."""
    if not accel.enabled():
        return None
    return library()[0]


def _columns(block: pa.Table):
    """(kinds, the columns' values as contiguous arrays) or None when a column is of a kind C does not write."""
    kinds = []
    arrays = []
    for col in block.columns:
        kind = KINDS.get(col.type)
        if kind is None or col.null_count:
            return None
        values = to_numpy(col)
        if kind == KINDS[pa.bool_()]:
            values = values.view(np.uint8)
        arrays.append(np.ascontiguousarray(values))
        kinds.append(kind)
    return kinds, arrays


class Scratch:
    """The formatter's output buffer, kept from block to block: a fresh one of ~8 MB for each block was a few
    thousand page faults each time (the kernel clearing every page before the formatter wrote it)."""

    def __init__(self):
        self._buf = np.empty(0, dtype=np.uint8)

    def get(self, size: int) -> np.ndarray:
        if self._buf.size < size:
            self._buf = np.empty(size, dtype=np.uint8)
        return self._buf


def rows_in_chunks(lib, block: pa.Table, scratch: Scratch | None = None):
    """The CSV text of ``block``'s rows as byte chunks (views of one reused buffer, ``scratch``'s when given:
    write each before taking the next), or None when the table has a column C does not write."""
    found = _columns(block)
    if found is None:
        return None
    kinds, arrays = found
    ncols, nrows = len(kinds), block.num_rows
    return _chunks(lib, kinds, arrays, ncols, nrows, scratch or Scratch())


FLOATING = (KINDS[pa.float64()], KINDS[pa.float32()])


def same_as(kinds, arrays) -> np.ndarray:
    """For each column, the first earlier floating-point column of its kind with the same bits in every row (an
    alias variable: the formatter copies that column's text), or -1. Candidates are found by their first, middle
    and last values, then compared whole (bits, so 0.0 and -0.0 or two NaNs are told apart)."""
    found = np.full(len(kinds), -1, dtype=np.int32)
    first: dict = {}
    for c, (kind, values) in enumerate(zip(kinds, arrays)):
        if kind not in FLOATING or values.size == 0:
            continue
        bits = values.view(np.uint64 if kind == FLOATING[0] else np.uint32)
        key = (kind, int(bits[0]), int(bits[bits.size // 2]), int(bits[-1]))
        for other in first.get(key, ()):
            if np.array_equal(bits, arrays[other].view(bits.dtype)):
                found[c] = other
                break
        else:
            first.setdefault(key, []).append(c)
    return found


def _chunks(lib, kinds, arrays, ncols, nrows, scratch):
    if nrows == 0 or ncols == 0:
        return
    kind_arr = np.array(kinds, dtype=np.int32)
    addresses = np.array([a.ctypes.data for a in arrays], dtype=np.uintp)
    aliases = same_as(kinds, arrays)
    rows = max(1, CHUNK_CELLS // ncols)
    buf = scratch.get(min(rows, nrows) * (CELL_BYTES * ncols + 1) + ROOM_BYTES)
    view = memoryview(buf)
    for row0 in range(0, nrows, rows):
        n = min(rows, nrows - row0)
        written = lib.cm_csv_rows(ncols, kind_arr.ctypes.data, addresses.ctypes.data, aliases.ctypes.data, row0, n,
                                  buf.ctypes.data)
        if written < 0:
            raise MemoryError("the CSV formatter has no power tables or no memory")
        yield view[:written]


def native_chunks(block: pa.Table, scratch: Scratch | None = None):
    """What CsvSink writes for ``block`` through C (byte chunks), or None: the reference writes it."""
    lib = formatter()
    return rows_in_chunks(lib, block, scratch) if lib is not None else None


def hard_doubles(rng: np.random.Generator, n: int, part: int = 0) -> dict[str, np.ndarray]:
    """About ``n`` doubles in each of the groups where a shortest-digits method goes wrong if it does (the formatter
    against repr: tests/master/sinks/test_csv_shortest.py a few million, bench/recording/check_shortest.py as many
    as asked), by name: random bits (every exponent, subnormals, NaNs and infinities); every binary exponent with
    mantissas at its ends (the powers of two, whose interval is narrower below); the smallest subnormals (few
    digits of precision); exact ties (integers and halves up to 2^54 and beyond, where the digits after the last one
    kept are exactly 5); short decimals at every decimal exponent (the rounded ends of the interval decide); and
    values a simulation writes. ``part``: the smallest subnormals from the (part * n + 1)-th on."""
    u64 = np.uint64
    exps = np.arange(2047, dtype=u64) << u64(52)
    ends = np.array([0, 1, 2, 3, (1 << 52) - 2, (1 << 52) - 1], dtype=u64)
    per_exponent = max(1, n // 2047 - len(ends))
    mids = rng.integers(0, 1 << 52, size=(2047, per_exponent), dtype=u64)
    halves = rng.integers(1 << 40, 1 << 56, size=n, dtype=np.int64).astype(np.float64) / 2.0 ** rng.integers(0, 3, n)
    digits = rng.integers(1, 10 ** rng.integers(1, 18, n), dtype=np.int64, endpoint=False)
    decimals = np.array([float(f"{d}e{e}") for d, e in zip(digits[: n // 4].tolist(),
                                                            rng.integers(-330, 300, n // 4).tolist())])
    return {
        "random bits": rng.integers(0, 2 ** 64, n, dtype=u64, endpoint=False).view(np.float64),
        "every exponent, mantissas at its ends and between":
            np.concatenate([(exps[:, None] | ends).ravel(), (exps[:, None] | mids).ravel()]).view(np.float64),
        "smallest subnormals": np.arange(part * n + 1, (part + 1) * n + 1, dtype=u64).view(np.float64),
        "integers and halves (ties)": np.concatenate([halves, -halves[: n // 8]]),
        "short decimals": decimals,
        "values a simulation writes": rng.uniform(-1e3, 1e3, n) * 10.0 ** rng.integers(-8, 20, n),
    }


class CsvFormat:
    """The C CSV formatter as an accelerator of ``format_rows``: both give the same text for tables of every
    numeric Arrow type, Booleans, and doubles of every kind (random bits, so subnormals, NaNs and infinities;
    powers of two and ten and their neighbours, where the shortest decimal is decided by its ends; integers,
    ties, the limits of fixed notation)."""
    name = "master.csv-format"
    replaces = "master.sinks.csv_text:format_rows"

    def load(self):
        if not accel.enabled():
            return None, f"{accel.ENV} is set"
        lib, why = library()
        return (lib, None) if lib is not None else (None, why)

    def cases(self, rng):
        for _ in range(6):
            yield self._doubles(rng, 3000)
        for _ in range(4):
            yield self._mixed(rng, rng.randrange(0, 40))
        for _ in range(3):
            yield self._repeating(rng, rng.randrange(1, 400))
        for rows in (1, 2, rng.randrange(3, 400), 6000):      # 6000 rows: more than one chunk (CHUNK_CELLS)
            yield self._aliased(rng, rows)

    @staticmethod
    def _double(rng) -> float:
        pick = rng.random()
        if pick < 0.35:         # any bit pattern
            return struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
        if pick < 0.5:          # a power of two or ten, or one of its neighbours
            base = 2.0 ** rng.randrange(-1074, 1024) if rng.random() < 0.5 else 10.0 ** rng.randrange(-323, 309)
            bits = struct.unpack("<Q", struct.pack("<d", base))[0] + rng.randrange(-2, 3)
            return struct.unpack("<d", struct.pack("<Q", min(max(bits, 0), (1 << 64) - 1)))[0]
        if pick < 0.65:         # a short decimal, near the ends of fixed notation
            return float(f"{rng.randrange(1, 10 ** rng.randrange(1, 18))}e{rng.randrange(-25, 25)}")
        if pick < 0.75:         # an integer (ties when it has more than 17 digits)
            return float(rng.randrange(-(1 << 70), 1 << 70) >> rng.randrange(0, 70))
        if pick < 0.8:
            return rng.choice([0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 2.2250738585072014e-308,
                               1.7976931348623157e308, 1e16, 1e-4, 9999999999999998.0, 0.1, 0.3])
        return rng.uniform(-1e3, 1e3) * 10.0 ** rng.randrange(-6, 20)       # values a simulation writes

    def _doubles(self, rng, n):
        cols = rng.randrange(1, 9)
        rows = n // cols
        return pa.table({f"c{k}": pa.array([self._double(rng) for _ in range(rows)], pa.float64())
                         for k in range(cols)})

    def _mixed(self, rng, rows):
        cols = {}
        for k, typ in enumerate(KINDS):
            if typ == pa.bool_():
                cols[f"b{k}"] = pa.array([rng.random() < 0.5 for _ in range(rows)], typ)
            elif pa.types.is_floating(typ):
                with np.errstate(over="ignore"):      # a double beyond float32 becomes an infinity
                    values = np.array([self._double(rng) for _ in range(rows)], dtype=typ.to_pandas_dtype())
                cols[f"f{k}"] = pa.array(values, typ)
            else:
                info = np.iinfo(typ.to_pandas_dtype())
                values = [rng.choice([info.min, info.max, 0, rng.randrange(info.min, info.max + 1)])
                          for _ in range(rows)]
                cols[f"i{k}"] = pa.array(values, typ)
        order = list(cols)
        rng.shuffle(order)
        return pa.table({name: cols[name] for name in order})

    def _repeating(self, rng, rows):
        """Columns whose values repeat the row above (copied, not formatted again) or change to a neighbour
        (0.0 and -0.0, NaNs of other payloads) or a value of a text of another length."""
        cols = {}
        for k in range(rng.randrange(1, 6)):
            pool = [self._double(rng) for _ in range(3)] + [0.0, -0.0, math.nan, -math.nan]
            values, v = [], rng.choice(pool)
            for _ in range(rows):
                if rng.random() < 0.3:
                    v = rng.choice(pool)
                values.append(v)
            typ = rng.choice([pa.float64(), pa.float32()])
            with np.errstate(over="ignore"):
                cols[f"r{k}"] = pa.array(np.array(values, dtype=typ.to_pandas_dtype()), typ)
        return pa.table(cols)

    def _aliased(self, rng, rows):
        """Columns that are other columns' copies (alias variables, whose text is copied) among look-alikes that
        are not: the same first, middle and last values with one other value changed, 0.0 for -0.0 or a NaN of
        another payload somewhere, the same values as float32, an integer column with a double column's bits."""
        bases = {}
        for k in range(rng.randrange(1, 4)):
            typ = rng.choice([pa.float64(), pa.float64(), pa.float32()])
            with np.errstate(over="ignore"):
                bases[f"a{k}"] = np.array([self._double(rng) for _ in range(rows)], dtype=typ.to_pandas_dtype())
            if rows > 3:        # a zero where a look-alike has the other one
                bases[f"a{k}"][1] = rng.choice([0.0, -0.0])
        cols = dict(bases)
        for k in range(rng.randrange(4, 12)):
            name, values = rng.choice(list(bases.items()))
            values = values.copy()
            tweak = rng.randrange(0, 6) if rows > 3 else 0
            i = rng.choice([j for j in range(rows) if j not in (0, rows // 2, rows - 1)] or [0])
            if tweak == 1:
                with np.errstate(over="ignore"):
                    values[i] = self._double(rng)
            elif tweak == 2:        # the other zero: equal (==), not the same bits
                values[1] = 0.0 if np.signbit(values[1]) else -0.0
            elif tweak == 3:
                bits = values.view(np.uint64 if values.itemsize == 8 else np.uint32)
                bits[i] = (0x7FF8000000000001 + k) if values.itemsize == 8 else (0x7FC00001 + k)
            elif tweak == 4:
                with np.errstate(over="ignore", invalid="ignore"):
                    values = values.astype(np.float32 if values.itemsize == 8 else np.float64)
            elif tweak == 5 and values.itemsize == 8:
                cols[f"i{k}"] = pa.array(values.view(np.int64), pa.int64())
                continue
            cols[f"c{k}_{name}"] = values
        order = list(cols)
        rng.shuffle(order)
        return pa.table({n: cols[n] if isinstance(cols[n], pa.Array) else pa.array(cols[n]) for n in order})

    def reference(self, case):
        return format_rows(case).encode()

    def accelerated(self, impl, case):
        return b"".join(bytes(c) for c in (rows_in_chunks(impl, case) or [b"(not taken)"]))


CSV_FORMAT = CsvFormat()
