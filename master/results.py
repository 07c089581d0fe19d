"""Reading a run's recorded results back (the one place that knows the file layout of a run folder)."""
from __future__ import annotations

import math
import os
from pathlib import Path

PARQUET = "results.parquet"
RUN_JSON = "run.json"


LOCK_NAME = ".cosim-master.lock"            # held (flock) by the run writing into the folder
PREVIOUS_NAME = ".cosim-master.previous"    # the earlier run's products, until the new run has results
_OWN = (LOCK_NAME, PREVIOUS_NAME)
_locks: dict = {}                           # folder -> open lock file of a run of this process


def claim_output_folder(out_dir) -> None:
    """A run owns its folder: create it, or take over an earlier run's folder. The earlier run's products (run.json
    lists them) are moved aside as a whole, so that no file of another run is left beside the new results, and
    stay there until the new run has results (``settle_output_folder``): a rerun that fails or is interrupted
    before its first row gives the folder back as it was. A non-empty folder that holds no run.json is someone
    else's and is refused; so is a folder another run is writing into."""
    from .errors import CosimError
    out_dir = Path(out_dir)

    def refuse(reason):
        return CosimError(reason, file=str(out_dir), element="--output")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise refuse("cannot create the output folder: a file of that name exists") from None
    except OSError as exc:
        raise refuse(f"cannot create the output folder: {exc.strerror or exc}") from None
    _lock(out_dir, refuse)
    try:
        if (out_dir / PREVIOUS_NAME).is_dir():      # a run killed before it had results: its predecessor comes back
            _restore_previous(out_dir)
        entries = [p for p in out_dir.iterdir() if p.name not in _OWN]
        if not entries:
            return
        run_json = out_dir / RUN_JSON
        if not run_json.is_file():
            raise refuse("the output folder is not empty and holds no earlier run (no run.json): choose another "
                         "folder or empty it")
        import json         # only here: a run into a new folder, whose start is the run's, does not need it
        try:
            products = json.loads(run_json.read_text(encoding="utf-8")).get("products")
        except (OSError, ValueError):
            products = None
        if not isinstance(products, list):      # a run of an older version: its folder held its files only
            products = [p.name for p in entries if p.is_file()]
        aside = out_dir / PREVIOUS_NAME
        names = [str(n) for n in {*products, RUN_JSON}
                 if str(n) not in _OWN and (out_dir / str(n)).parent == out_dir and (out_dir / str(n)).exists()]
        try:
            aside.mkdir()
            for n in sorted(names):
                os.rename(out_dir / n, aside / n)
        except OSError as exc:
            _restore_previous(out_dir)
            raise refuse(f"cannot replace the earlier run's files: {exc.strerror or exc}") from None
    except BaseException:
        release_output_folder(out_dir, refused=True)
        raise


def _lock(out_dir: Path, refuse) -> None:
    import fcntl
    if out_dir.resolve() in _locks:
        return
    path = out_dir / LOCK_NAME
    try:
        try:
            fd, created = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644), True
        except FileExistsError:
            fd, created = os.open(path, os.O_RDWR), False
    except OSError as exc:      # a read-only folder: said here, before anything else tries to write there
        raise refuse(f"cannot write into the output folder: {exc.strerror or exc}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise refuse("another cosim-master run is writing into this output folder: wait for it to end or choose "
                     "another folder") from None
    _locks[out_dir.resolve()] = (fd, path if created else None)


def release_output_folder(out_dir, refused: bool = False) -> None:
    """The run is over: another may take the folder (the lock file stays; it is not a product). A folder that was
    refused is left as it was found."""
    fd, created = _locks.pop(Path(out_dir).resolve(), (None, None))
    if fd is not None:
        if refused and created is not None:
            created.unlink(missing_ok=True)
        os.close(fd)


def settle_output_folder(out_dir, has_results: bool) -> bool:
    """The earlier run's products, moved aside by ``claim_output_folder``, go for good once the new run has results;
    without any (it failed or was stopped before its first row) they come back in place of the new run's files.
    Returns True when the earlier run was given back."""
    import shutil
    aside = Path(out_dir) / PREVIOUS_NAME
    if not aside.is_dir():
        return False
    if has_results:
        shutil.rmtree(aside, ignore_errors=True)
        return False
    return _restore_previous(Path(out_dir))


def _restore_previous(out_dir: Path) -> bool:
    import json
    import shutil
    aside = out_dir / PREVIOUS_NAME
    try:
        new = json.loads((out_dir / RUN_JSON).read_text(encoding="utf-8")).get("products")
    except (OSError, ValueError):
        new = None
    kept = set(os.listdir(aside))
    try:
        # the new run's files: those its run.json lists, or (none written) the ones the earlier run also had
        for n in set(new if isinstance(new, list) else []) | kept:
            p = out_dir / str(n)
            if str(n) in _OWN or p.parent != out_dir:
                continue
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink(missing_ok=True)
        for n in kept:
            os.rename(aside / n, out_dir / n)
        aside.rmdir()
    except OSError:
        return False
    return True


def products(out_dir) -> list[str]:
    """What a run wrote into its folder (run.json lists it for the next run into the same folder)."""
    return sorted({p.name for p in Path(out_dir).iterdir()
                   if not p.name.endswith(".tmp") and p.name not in _OWN} | {RUN_JSON})


def results_path(out_dir) -> Path:
    return Path(out_dir) / PARQUET


def result_columns(out_dir) -> list[str]:
    import pyarrow.parquet as pq
    return pq.read_schema(results_path(out_dir)).names


def read_results(out_dir, columns: list[str] | None = None):
    """The recorded series of a run folder as a pandas DataFrame (all columns, or those named)."""
    return read_parquet_frame(Path(out_dir) / PARQUET, columns)


READ_COLUMNS = 256


def read_parquet_frame(path, columns: list[str] | None = None):
    """A Parquet file as a pandas DataFrame, equal to ``pandas.read_parquet``'s, in a fraction of its memory
    for wide files: the fixed-width columns (numbers, booleans) without nulls are copied row group by row
    group into one preallocated array per type, which the frame then holds as it is; pyarrow's own
    conversion of a whole table needs several times the frame (measured, 3601 rows x 8000 doubles = 230 MB:
    0.9 GB in one row group, 2.7 GB in 512-row groups; this way 0.4 GB either way)."""
    import numpy as np
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq
    pf = pq.ParquetFile(str(path))
    schema = pf.schema_arrow
    names = list(schema.names) if columns is None else list(columns)
    meta = pf.metadata
    plain = (meta.num_rows > 0 and names and not (schema.metadata and b"pandas" in schema.metadata)
             and len(set(schema.names)) == len(schema.names) and len(set(names)) == len(names)
             and set(names) <= set(schema.names))
    if not plain:       # pandas' index metadata, duplicate or unknown names (its own error), nothing to read
        return pd.read_parquet(path, columns=columns)
    by_dtype: dict = {}
    rest = []
    for n in names:
        typ = schema.field(n).type
        if pa.types.is_integer(typ) or pa.types.is_boolean(typ) or typ in (pa.float32(), pa.float64()):
            by_dtype.setdefault(np.dtype(typ.to_pandas_dtype()), []).append(n)
        else:
            rest.append(n)
    rows = meta.num_rows
    arrays = {dt: np.empty((rows, len(cols)), dtype=dt, order="F") for dt, cols in by_dtype.items()}
    r = 0
    # a few hundred columns of one row group at a time: the reader's buffers grow with both
    where = [(arrays[dt], j, n) for dt, cols in by_dtype.items() for j, n in enumerate(cols)]
    for g in range(meta.num_row_groups):
        m = meta.row_group(g).num_rows
        for a in range(0, len(where), READ_COLUMNS):
            part = where[a:a + READ_COLUMNS]
            t = pf.read_row_group(g, columns=[n for _, _, n in part], use_threads=False)
            for (out, j, n), col in zip(part, t.columns):
                if col.null_count:      # pandas would make it float or object: leave the file to pyarrow
                    return pd.read_parquet(path, columns=columns)
                out[r:r + m, j] = col.to_numpy()
            del t
        r += m
    # copy=False: the frame holds the filled arrays (pandas copies a 2D array by default)
    parts = [pd.DataFrame(arrays[dt], columns=cols, copy=False) for dt, cols in by_dtype.items()]
    if rest:
        parts.append(pq.read_table(str(path), columns=rest, use_threads=False).to_pandas())
    frame = pd.concat(parts, axis=1) if len(parts) != 1 else parts[0]
    return frame[names]


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


# ------------------------------------------------------------------------------- small CSVs without pandas
# A campaign run writes events.csv, photos.csv and summary.csv of a few rows each, and building pandas frames
# for them cost more than the rest of the run's outputs (and a worker's start-up paid ~0.2 s to import pandas
# for them).  The twin below gives pandas' bytes for the values monitors make (str, int, float, bool, None): each column's cells are what DataFrame(rows) and to_csv(index=
# False) hand to the csv module (the dtype pandas infers, numpy's float formatting, empty cells for missing
# values), written by the csv module with pandas' dialect.  Any other value, or a case whose pandas outcome is
# an error, makes them decline (nothing written) and the frame is built as before
# (tests/master/campaign/test_campaign_outputs_csv.py and tests/master/test_events_csv.py compare both on thousands
# of random tables).
_CSV_PLAIN_TYPES = frozenset((str, int, float, bool, type(None)))


def csv_column_cells(values: list, as_int64: bool = False) -> list | None:
    """The cells of a column of ``values`` (from dicts, as pandas infers it; ``as_int64``: then ``astype("Int64")``),
    or None when the twin does not cover them."""
    kinds = {type(v) for v in values}
    if not kinds <= _CSV_PLAIN_TYPES:
        return None
    missing = [v is None or (type(v) is float and v != v) for v in values]
    numeric = kinds - {type(None)}
    if as_int64:
        return _int64_cells(values, missing, numeric)
    if not numeric or str in numeric or bool in numeric and numeric != {bool}:
        # an object column: the values themselves (the csv module formats them), missing ones empty
        return ["" if na else v for v, na in zip(values, missing)]
    if numeric == {bool}:
        return ["" if na else str(v) for v, na in zip(values, missing)]
    if numeric == {int} and not any(missing):
        return [str(v) for v in values] if all(-2 ** 63 <= v < 2 ** 63 for v in values) else None
    # float64: numpy's shortest round-trip text, as pandas' astype(str); missing values empty
    if any(type(v) is int and abs(v) > 2 ** 53 for v in values):
        return None
    import numpy as np
    text = np.array([math.nan if na else float(v) for v, na in zip(values, missing)], dtype=np.float64).astype(str)
    return ["" if na else t for t, na in zip(text.tolist(), missing)]


def _int64_cells(values: list, missing: list, numeric: set) -> list | None:
    """The cells of a column that pandas infers and then casts to its nullable Int64."""
    if not numeric <= {int, float}:
        return None
    out = []
    for v, na in zip(values, missing):
        if na:
            out.append("")
        elif type(v) is int:
            if numeric == {float, int} and abs(v) > 2 ** 53:
                return None     # through float64 first: pandas' rounding, or its error
            if not -2 ** 63 <= v < 2 ** 63:
                return None
            out.append(str(v))
        elif v.is_integer() and abs(v) <= 2 ** 53:
            out.append(str(int(v)))
        else:
            return None         # pandas refuses the cast, with its own error message
    return out


def write_csv_cells(path: Path, columns: list[str], cells: list[list]) -> None:
    """Rows of ``cells`` (one list per column) under ``columns``, with pandas' to_csv dialect."""
    import csv
    with open(path, "w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n", delimiter=",", quotechar='"', quoting=csv.QUOTE_MINIMAL,
                       doublequote=True, escapechar=None)
        w.writerow(columns)
        w.writerows(zip(*cells))



def write_events_csv(events: list[dict], path) -> bool:
    """events.csv as ``pandas.DataFrame(events).to_csv(path, index=False)`` writes it (the columns in the order
    their keys first appear, a key missing from an event an empty cell); False (nothing written) when the
    values are not all of the plain kinds the twin covers."""
    columns: dict = {}
    for e in events:
        if type(e) is not dict:
            return False
        columns.update(dict.fromkeys(e))
    if not events or not all(type(c) is str for c in columns):
        return False
    cells = []
    for c in columns:
        col = csv_column_cells([e.get(c) for e in events])
        if col is None:
            return False
        cells.append(col)
    write_csv_cells(Path(path), list(columns), cells)
    return True
