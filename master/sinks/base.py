"""The sink interface."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:       # a supervised run's simulation process has sinks of its own but no pyarrow
    import pyarrow as pa


class Sink:
    """Receives the recorded rows a block at a time. ``out_dir`` is None for a run kept in memory; a sink that
    needs a folder then does nothing (``needs_folder``)."""
    needs_folder = True

    def open(self, out_dir: Path | None, schema: pa.Schema) -> None:
        self.out_dir, self.schema = out_dir, schema

    def write(self, block: pa.Table) -> None:
        raise NotImplementedError

    def close(self) -> None:
        pass

    # -- all-or-nothing blocks (SinkGroup) ----------------------------------------------------------------
    broken = False

    def mark(self):
        """Where the sink stands before a block (``rollback`` returns there)."""
        return None

    def rollback(self, mark) -> None:
        """Undo what was written since ``mark``; a sink that cannot undo is ``broken`` and gets ``repair``."""
        self.broken = True

    def repair(self, sinks: list, schema, rows: int) -> str:
        """Make the output whole again at close (``rows`` blocks-worth were written everywhere); returns a note
        for run.json."""
        return f"{type(self).__name__} was left incomplete"

    def files(self) -> list[Path]:
        """The files this sink wrote (listed in run.json)."""
        return []
