"""Input signals from a file: a CSV table as a slave whose outputs are its columns at the current time.

The table is an SSD component of type ``text/csv`` (OMSimulator's convention: its output connectors are named as
the CSV's columns) or the file given with ``run --input`` (the FMI cross-check ``<Model>_in.csv``: a ``time``
column, then one column per input). It has no FMU file, but runs through the same Execution machinery as one: the
plan gives it a variable per connected column (typed as the input it drives) and a stand-in for the FMU's
description (:func:`csv_source`), and the factory chooses :class:`CsvSourceSlave` for it.

Between rows a column is interpolated as the FMI cross-check rules do for the input it drives: a continuous
Real input linearly, every other (discrete, fixed, tunable; integers, Booleans, strings) holds the last row at or
before the time. Before the first row a column has its first value, after the last row its last one.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cache_paths import file_sha256
from ..errors import ScenarioError
from .cache import CSV_KIND, LoadedFmu  # noqa: F401 - CSV_KIND: the kind of the slaves made here
from .slave import ERROR, OK, Port, Slave

# the master's time is start + n*h; a product that lands a rounding error short of a row's time still reaches it
_AT_ROW = 1e-12


@dataclass
class CsvTable:
    """A CSV file read as text: the time of each row and each column's raw values (parsed when its type is
    known, see :func:`column_values`)."""
    path: Path
    times: np.ndarray
    columns: dict[str, list[str]]


def read_csv_table(path: Path, shown_as: str) -> CsvTable:
    """The table of ``path``: a header whose first column is ``time``, then rows of as many fields, their times
    numbers that never decrease (a time given twice is a step in the signal: the later row holds from then)."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read the input table: {exc}", file=shown_as) from None
    rows = [r for r in rows if r]
    if not rows or rows[0][0].strip().lower() != "time":
        raise ScenarioError("an input table's first column must be 'time'", file=shown_as, line=1)
    header = [name.strip() for name in rows[0]]
    if len(rows) < 2:
        raise ScenarioError("the input table has no rows", file=shown_as)
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ScenarioError(f"{len(row)} fields where the header has {len(header)}", file=shown_as, line=line)
    times = np.array([_number(r[0], shown_as, line) for line, r in enumerate(rows[1:], start=2)])
    if np.any(np.diff(times) < 0):
        line = int(np.flatnonzero(np.diff(times) < 0)[0]) + 3
        raise ScenarioError("the times of an input table must not decrease", file=shown_as, line=line)
    return CsvTable(Path(path), times, {name: [r[k] for r in rows[1:]] for k, name in enumerate(header) if k})


def _number(raw: str, shown_as: str, line: int) -> float:
    try:
        return float(raw)
    except ValueError:
        raise ScenarioError(f"time {raw!r} is not a number", file=shown_as, line=line) from None


# how the text of a cell becomes a value of each base type; integers are read exactly (Int64 and UInt64
# extremes are beyond a double), and an integral number written as a decimal (3.0) is accepted
_PARSE = {
    "Real": float,
    "Integer": lambda s: int(s) if s.lstrip("+-").isdigit() else _integral(s),
    "Boolean": lambda s: {"true": True, "1": True, "false": False, "0": False}[s.lower()],
    "String": str,
    "Binary": bytes.fromhex,
}
_PARSE["Int64"] = _PARSE["UInt64"] = _PARSE["Integer"]


def _integral(s: str) -> int:
    x = float(s)
    if not x.is_integer():
        raise ValueError(s)
    return int(x)


def column_values(table: CsvTable, column: str, typ: str, shown_as: str) -> list:
    """The column's cells as values of the base type ``typ``; a cell that is not one is an error naming it."""
    out = []
    for line, raw in enumerate(table.columns[column], start=2):
        try:
            out.append(_PARSE[typ](raw.strip()))
        except (ValueError, KeyError):
            raise ScenarioError(f"{raw!r} in column {column!r} is not a valid {typ}", file=shown_as,
                                line=line) from None
    return out


@dataclass
class TableColumn:
    """One column as the slave serves it: its value reference, its values (one per row) and how it is
    interpolated."""
    vr: int
    values: list
    linear: bool


@dataclass
class TableDescription:
    """What the master reads of an FMU's modelDescription, for a table (it has no FMU file)."""
    table: CsvTable
    columns: dict[int, TableColumn]
    modelName: str
    fmiVersion: str = "-"
    generationTool: str | None = None
    guid: str = ""
    defaultExperiment: object = None
    coSimulation: object = None
    modelExchange: object = None
    modelVariables: list = field(default_factory=list)
    outputs: list = field(default_factory=list)
    unitDefinitions: list = field(default_factory=list)


def csv_source(table: CsvTable, columns: list[TableColumn]) -> LoadedFmu:
    """A table as the plan keeps an FMU: its file, hash, folder and description."""
    description = TableDescription(table, {c.vr: c for c in columns}, table.path.name)
    return LoadedFmu(table.path, file_sha256(table.path), table.path.parent, description, kind=CSV_KIND)


class CsvSourceSlave(Slave):
    """A table as a slave: no inputs, its outputs are its columns at the time its last step reached."""
    kind = CSV_KIND
    can_save_state = True         # its state is the time

    def __init__(self, name, fmu, log, shown_as, logging_on=False):
        super().__init__(name, fmu, log, shown_as)
        self.times = fmu.md.table.times
        self.columns = fmu.md.columns
        self.t = 0.0

    # -- life cycle: only the time moves ------------------------------------------------------------------
    def instantiate(self):
        self.instantiated = True

    def setup(self, start, stop, tolerance=None):
        self.t = start

    def enter_init(self, t):
        self.t = t

    def exit_init(self, t):
        self.initialized = True

    def do_step(self, t, h) -> int:
        self.t = t + h
        return OK

    def terminate(self) -> int:
        self.initialized = False
        return OK

    def free(self):
        self.instantiated = False

    def save_state(self, t=None):
        return self.t

    def restore_state(self, token, t=None):
        self.t = token

    # -- values -------------------------------------------------------------------------------------------
    def set_value(self, typ, vr, value) -> int:
        self.log.message(self.name, "error", "the columns of an input table cannot be given values")
        return ERROR

    def make_port(self, typ, vrs, buf) -> Port:
        """The port's columns side by side (a row per table row, in the buffer's type) and which of them are
        interpolated linearly."""
        port = Port(vrs, buf, None, native=False)
        cols = [self.columns[int(vr)] for vr in port.vrs]
        values = np.array([c.values for c in cols], dtype=buf.dtype).T.copy()
        port.extra = (values, np.array([c.linear for c in cols], dtype=bool))
        return port

    def get_port(self, typ, port) -> int:
        values, linear = port.extra
        lo, hi, weight = self._bracket()
        port.buf[:] = values[lo]
        if weight and linear.any():
            a, b = values[lo, linear], values[hi, linear]
            port.buf[linear] = a + weight * (b - a)
        return OK

    def _bracket(self) -> tuple[int, int, float]:
        """The rows around the current time and the weight of the later one: the last row at or before the time
        and the next; both the first row before it, both the last after it."""
        t, times = self.t, self.times
        i = int(np.searchsorted(times, t + _AT_ROW * max(1.0, abs(t)), side="right"))
        lo, hi = max(i - 1, 0), min(i, len(times) - 1)
        if lo == hi:
            return lo, hi, 0.0
        return lo, hi, max(0.0, (t - times[lo]) / (times[hi] - times[lo]))

    def set_port(self, typ, port) -> int:
        return OK           # a table has no inputs; the plan refuses connections into it
