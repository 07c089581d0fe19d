"""Reading a run's recorded results back (the one place that knows the file layout of a run folder)."""
from __future__ import annotations

import math
from pathlib import Path

PARQUET = "results.parquet"


def results_path(out_dir) -> Path:
    return Path(out_dir) / PARQUET


def result_columns(out_dir) -> list[str]:
    import pyarrow.parquet as pq
    return pq.read_schema(results_path(out_dir)).names


def read_results(out_dir, columns: list[str] | None = None):
    """The recorded series of a run folder as a pandas DataFrame (all columns, or those named)."""
    import pandas as pd
    return pd.read_parquet(Path(out_dir) / PARQUET, columns=columns)


def final_values(out_dir) -> dict:
    """The last recorded value of every numeric or boolean column ({} when nothing readable was recorded)."""
    p = Path(out_dir) / PARQUET
    if not p.is_file():
        return {}
    import pyarrow.parquet as pq
    try:
        pf = pq.ParquetFile(str(p))
        if pf.metadata.num_rows == 0:
            return {}
        t = pf.read_row_group(pf.num_row_groups - 1)
    except Exception:   # noqa: BLE001 - a truncated file after a failure
        return {}
    out = {}
    for name in t.column_names:
        col = t.column(name)
        if len(col) == 0:
            continue
        v = col[len(col) - 1].as_py()
        if isinstance(v, bool):
            out[name] = v
        elif isinstance(v, (int, float)):
            out[name] = v if not (isinstance(v, float) and not math.isfinite(v)) else None
    return out
