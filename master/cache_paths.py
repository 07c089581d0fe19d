"""Where the per-user cache lives, and the content hash every cache is keyed by.

The FMU cache (unpacked FMUs, ``fmi/cache.py``), the store of FMUs linked out of SSP archives
(``ssp/archive.py``), the compiled C sources (``native_build.py``) and the validation records (``ValidationRecord``:
SSDs, ``ssp/xsd.py``; FMU descriptions, ``fmi/cache.py``) share one root; each keeps a folder of its own under it.
Kept apart from all of them so that none of them has to import another for a path or a hash.
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


#: validation records kept at most; beyond, the oldest half goes (a run of a scenario not seen before writes one, so
#: a machine that runs thousands of generated SSPs would otherwise keep a file for each)
MAX_VALIDATION_RECORDS = 4000


def fmpy_validator() -> bytes:
    """The identity of a validation made with fmpy's files, for a ``ValidationRecord``: fmpy's version (its
    schemas and rules) and libxml2's (which applies the schemas), as ``fmpy <version> libxml2 <version>``. One
    definition for both records (FMU descriptions, ``fmi/cache.py``; SSDs, ``ssp/xsd.py``). Imported when asked,
    by a validation, which has loaded fmpy and lxml by then: loading this module (every run does) loads neither."""
    from fmpy import __version__ as fmpy_version
    from lxml import etree
    return f"fmpy {fmpy_version} libxml2 {etree.LIBXML_VERSION}".encode()


class ValidationRecord:
    """That a document passed a validation, remembered across processes: an empty file under
    ``<cache>/validated/`` named by the SHA-256 of what decides the outcome (``parts``: the validator's identity and
    the exact bytes validated, each given with its length). Nothing else is trusted: other bytes or another
    validator make another name, which is validated as if never seen."""
    def __init__(self, *parts: bytes):
        h = hashlib.sha256()
        for part in parts:
            h.update(b"%d:" % len(part))
            h.update(part)
        self.folder = cache_root() / "validated"
        self.path = self.folder / h.hexdigest()

    def passed(self) -> bool:
        return self.path.is_file()

    def remember(self) -> None:
        """Called once the validation passed. A cache folder that cannot be written is no error: the document is
        validated again next time."""
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            self.path.touch()
            names = os.listdir(self.folder)
            if len(names) > MAX_VALIDATION_RECORDS:
                _drop_oldest(self.folder, names, len(names) // 2)
        except OSError:
            pass


def _drop_oldest(folder: Path, names: list[str], count: int) -> None:
    aged = []
    for name in names:
        try:
            aged.append((os.stat(folder / name).st_mtime_ns, name))
        except OSError:         # another process dropped it first
            pass
    for _, name in sorted(aged)[:count]:
        try:
            os.unlink(folder / name)
        except OSError:
            pass
