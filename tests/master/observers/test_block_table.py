"""``block_table``: a block of rows (time, then numeric columns grouped by buffer type, 64-bit integers as their
bits) and the rows' String/Binary values as an Arrow table, compared with the table built value by value."""
import numpy as np
import pyarrow as pa

from master.observers.recording import NUMERIC_ORDER, _BASE_OF, block_table

TYPES = [pa.float64(), pa.int8(), pa.uint8(), pa.int16(), pa.uint16(), pa.int32(), pa.uint32(), pa.int64(),
         pa.uint64(), pa.bool_(), pa.string(), pa.binary()]


def test_every_column_type_is_its_values():
    rng = np.random.default_rng(11)
    for trial in range(15):
        fields = [pa.field(f"c{k}", TYPES[rng.integers(len(TYPES))]) for k in range(30)]
        rows = int(rng.integers(0, 40))
        values = {}
        for f in fields:       # what each column holds, as Python values
            t = f.type
            if pa.types.is_integer(t):
                info = np.iinfo(t.to_pandas_dtype())
                values[f.name] = [int(rng.integers(info.min, info.max, endpoint=True, dtype=t.to_pandas_dtype()))
                                  for _ in range(rows)]
            elif t == pa.bool_():
                values[f.name] = [bool(rng.random() < 0.5) for _ in range(rows)]
            elif t == pa.string():
                values[f.name] = [f"s{r}" for r in range(rows)]
            elif t == pa.binary():
                values[f.name] = [bytes([r % 256]) for r in range(rows)]
            else:
                values[f.name] = [float(x) for x in rng.standard_normal(rows)]
        time = [r * 0.25 for r in range(rows)]
        # the recording's layout: numeric columns by NUMERIC_ORDER (schema order within a type), objects per row
        kinds = [_BASE_OF[f.type] for f in fields]
        numeric = sorted((k for k, kind in enumerate(kinds) if kind not in ("String", "Binary")),
                         key=lambda k: NUMERIC_ORDER.index(kinds[k]))
        block = np.empty((rows, 1 + len(numeric)))
        block[:, 0] = time
        for col, k in enumerate(numeric, start=1):
            v = values[fields[k].name]
            if kinds[k] in ("Int64", "UInt64"):
                block[:, col] = np.array(v, dtype=np.dtype(kinds[k].lower())).view(np.float64)
            else:
                block[:, col] = np.array(v, dtype=np.float64)
        objects = [[values[f.name][r] for f in fields if f.type in (pa.string(), pa.binary())] for r in range(rows)]
        schema = pa.schema([pa.field("time", pa.float64())] + fields)
        got = block_table(schema, block, objects)
        got.validate(full=True)
        want = pa.table({"time": pa.array(time, pa.float64()),
                         **{f.name: pa.array(values[f.name], f.type) for f in fields}}, schema=schema)
        assert got.equals(want), trial
