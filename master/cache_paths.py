"""Where the per-user cache lives, and the content hash every cache is keyed by.

The FMU cache (unpacked FMUs, ``fmi/cache.py``), the store of FMUs linked out of SSP archives
(``ssp/archive.py``) and the compiled C sources (``native_build.py``) share one root; each keeps a folder of its
own under it.  Kept apart from all three so that none of them has to import another for a path or a hash.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path


def cache_root() -> Path:
    """``$COSIM_MASTER_CACHE``, else ``$XDG_CACHE_HOME/cosim-master/fmu`` (``~/.cache`` without it)."""
    env = os.environ.get("COSIM_MASTER_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "cosim-master" / "fmu"


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of the file's bytes, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
