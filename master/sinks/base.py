"""The sink interface."""
from __future__ import annotations

from pathlib import Path

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

    def files(self) -> list[Path]:
        """The files this sink wrote (listed in run.json)."""
        return []
