"""Recorded columns between NumPy and Arrow without pyarrow's pandas bridge.

pyarrow's own conversions (``pa.array`` of an ndarray or a list, ``Array.to_numpy``) first ask whether the values
are pandas objects, and asking imports pandas when it is installed: ~0.3 s, more than a short run's whole work, paid
by every process that records a row or writes a CSV line. A recorded column never is a pandas object: fixed-width
numbers and booleans without nulls, or lists of ``str``/``bytes``. These functions build and read the Arrow buffers
directly (the same bits as pyarrow's conversions; a contiguous ndarray is shared, not copied, as ``pa.array`` does)
and leave anything else to pyarrow.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

_OFFSET_LIMIT = 2**31 - 1          # a string/binary array's int32 offsets; longer data is left to pyarrow


def _numpy_dtype(typ: pa.DataType) -> np.dtype:
    return np.dtype(typ.to_pandas_dtype())      # for fixed-width types a NumPy dtype; pandas is not imported


def from_numpy(values: np.ndarray, typ: pa.DataType | None = None) -> pa.Array:
    """``pa.array(values, type=typ)`` for a 1-D array of numbers or booleans (``typ`` None: from its dtype)."""
    if typ is None:
        typ = pa.from_numpy_dtype(values.dtype)
    if pa.types.is_boolean(typ):
        bits = np.packbits(np.asarray(values, dtype=bool), bitorder="little")
        return pa.Array.from_buffers(typ, len(values), [None, pa.py_buffer(bits)])
    if not (pa.types.is_integer(typ) or pa.types.is_floating(typ)):
        return pa.array(values, type=typ)
    data = np.ascontiguousarray(values, dtype=_numpy_dtype(typ))
    return pa.Array.from_buffers(typ, len(data), [None, pa.py_buffer(data)])


def from_objects(values: list, typ: pa.DataType) -> pa.Array:
    """``pa.array(values, type=typ)`` for a list of ``str`` (``typ`` string) or ``bytes`` (``typ`` binary)."""
    kind = str if pa.types.is_string(typ) else bytes if pa.types.is_binary(typ) else None
    if kind is None or not all(type(v) is kind for v in values):    # nulls, other types: pyarrow decides
        return pa.array(values, type=typ)
    data = [v.encode("utf-8") for v in values] if kind is str else values
    offsets = np.zeros(len(data) + 1, dtype=np.int64)
    np.cumsum([len(d) for d in data], out=offsets[1:])
    if offsets[-1] > _OFFSET_LIMIT:
        return pa.array(values, type=typ)
    return pa.Array.from_buffers(typ, len(data), [None, pa.py_buffer(offsets.astype(np.int32)),
                                                  pa.py_buffer(b"".join(data))])


def to_numpy(column: pa.Array | pa.ChunkedArray) -> np.ndarray:
    """``column.to_numpy(zero_copy_only=False)``: numbers and booleans as their NumPy type (read-only where the
    Arrow memory is shared), strings and binaries as an object array of ``str``/``bytes``."""
    chunks = column.chunks if isinstance(column, pa.ChunkedArray) else [column]
    typ = column.type
    if pa.types.is_string(typ) or pa.types.is_binary(typ):
        out = np.empty(len(column), dtype=object)
        out[:] = column.to_pylist()
        return out
    fixed = pa.types.is_boolean(typ) or pa.types.is_integer(typ) or pa.types.is_floating(typ)
    if not fixed or column.null_count:
        return column.to_numpy(zero_copy_only=False)
    parts = [_chunk_values(c) for c in chunks]
    if len(parts) == 1:
        return parts[0]
    return np.concatenate(parts) if parts else np.empty(0, dtype=_numpy_dtype(typ))


def _chunk_values(chunk: pa.Array) -> np.ndarray:
    start, n = chunk.offset, len(chunk)
    boolean = pa.types.is_boolean(chunk.type)
    if n == 0:
        return np.empty(0, dtype=bool if boolean else _numpy_dtype(chunk.type))
    data = chunk.buffers()[1]
    if boolean:
        bits = np.unpackbits(np.frombuffer(data, dtype=np.uint8), bitorder="little", count=start + n)
        return bits[start:].astype(bool)
    return np.frombuffer(data, dtype=_numpy_dtype(chunk.type), count=start + n)[start:]
