"""Locating the SystemStructure.ssd of a scenario given as .ssp archive, folder or bare .ssd."""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import NamedTuple

from ..cache_paths import cache_root, file_sha256 as _plain_sha256
from ..errors import ScenarioError
from ..records import Record

SSD_NAME = "SystemStructure.ssd"


class MemoryArchive(NamedTuple):
    """An archive this process wrote, read from what the writer kept instead of a folder unpacked from it.  A named
    tuple, immutable as the frozen dataclass it was (a dataclass's methods are compiled from source in every
    process that defines it: ``master.records``)."""
    ssd: bytes              # the SystemStructure.ssd as written
    members: dict           # member name ("resources/X.fmu") -> the file holding its bytes (the FMU store's copy)
    validated: bool         # the writer validated the SSD against the schema
    shape: int | None = None    # SSDs the writer wrote with the same number have the same structure (None: unknown)


#: the folder archives are unpacked in (None: the temporary folder); a supervised run's simulation process
#: unpacks into one its supervisor removes when the process is gone, dead or alive (master.supervise)
UNPACK_DIR: str | None = None


class ScenarioSource(Record):
    """A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, path: Path, ssd_path: Path, root: Path, tempdir: Path | None = None,
                 memory: MemoryArchive | None = None):
        self.path = path            # what the user named
        self.ssd_path = ssd_path    # the SSD file on disk (in memory: where it would be, under the archive's path)
        self.root = root            # folder that component sources are relative to (in memory: the archive's path)
        self.tempdir = tempdir
        self.memory = memory

    @property
    def shown_root(self) -> str:
        """How files inside the scenario are named in messages: under the archive's or folder's name; files
        next to a bare .ssd keep their own paths."""
        return str(self.path) if self.tempdir is not None or self.root == self.path else ""

    def close(self) -> None:
        if self.tempdir is not None:
            shutil.rmtree(self.tempdir, ignore_errors=True)
            self.tempdir = None


def _extract_ssp(path: Path, seen: dict | None = None) -> Path:
    """Unpack the archive into a temporary folder.  ``seen`` (when given) gets what a later opening needs to lay the
    same folder out again without the archive: {"files": name -> bytes (None: a folder), "fmus": name -> (SHA-256,
    None)}, or stays empty when an FMU could not be linked or the other members are large."""
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise ScenarioError(f"not a readable SSP archive (zip): {exc}", file=path) from None
    with zf:
        names = zf.namelist()
        if SSD_NAME not in names:
            raise ScenarioError(f"archive has no {SSD_NAME} at its top level", file=path)
        tmp = Path(tempfile.mkdtemp(prefix="cosim-ssp-", dir=UNPACK_DIR))
        for name in names:
            target = (tmp / name).resolve()
            if not str(target).startswith(str(tmp.resolve()) + os.sep) and target != tmp.resolve():
                shutil.rmtree(tmp, ignore_errors=True)
                raise ScenarioError(f"archive member escapes the archive: {name}", file=path)
        files, fmus, size = {}, {}, 0
        try:
            for info in zf.infolist():
                linked = None
                if not info.is_dir() and info.filename.lower().endswith(".fmu"):
                    linked = _link_fmu(zf, info, tmp)
                    if linked:
                        fmus[info.filename] = (linked, None)
                        continue
                zf.extract(info, tmp)
                size += info.file_size
                if linked is not None:
                    size = _MAX_REMEMBERED_BYTES + 1        # an FMU of its own: lay it out from the archive
                elif info.is_dir():
                    files[info.filename] = None
                elif size <= _MAX_REMEMBERED_BYTES:
                    files[info.filename] = (tmp / info.filename).read_bytes()
        except (zipfile.BadZipFile, OSError, EOFError) as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            raise ScenarioError(f"corrupt SSP archive: {exc}", file=path) from None
    if seen is not None and size <= _MAX_REMEMBERED_BYTES:
        seen.update(files=files, fmus=fmus)
    return tmp


def _link_fmu(zf: zipfile.ZipFile, info: zipfile.ZipInfo, tmp: Path) -> str | None:
    """Put an FMU member in place as a link to one copy per content (``<FMU cache>/archived/<sha256>.fmu``)
    instead of a fresh file: a campaign unpacks the same FMUs from every run's archive, and the FMU cache
    (``master.fmi.cache``) knows a file it has hashed by its path and mtime, so it neither hashes nor unpacks the
    FMU again.  Returns the member's SHA-256; None (extract it as usual) where links cannot be made."""
    h = hashlib.sha256()
    with zf.open(info) as fh:            # reading to the end checks the member's CRC, as extract() does
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)

    def copy(out):
        with zf.open(info) as fh:
            shutil.copyfileobj(fh, out, 1 << 20)
    sha = h.hexdigest()
    return sha if _place_fmu(sha, copy, tmp / info.filename) else None


def _stored_fmu(sha: str, copy) -> Path:
    """The stored copy of the FMU whose bytes have SHA-256 ``sha`` (``copy(file)`` writes them when there is none
    yet); raises OSError where it cannot be written."""
    store = cache_root() / "archived"
    kept = store / f"{sha}.fmu"
    if not kept.is_file():
        store.mkdir(parents=True, exist_ok=True)
        part = store / f".{sha}.{os.getpid()}.tmp"
        with open(part, "wb") as out:
            copy(out)
        os.replace(part, kept)          # whole or absent, whichever process wins
    return kept


def _place_fmu(sha: str, copy, link: Path) -> bool:
    """Link ``link`` to the stored copy of the FMU whose bytes have SHA-256 ``sha`` (``copy(file)`` writes them
    when there is none yet); False where links cannot be made."""
    try:
        kept = _stored_fmu(sha, copy)
        link.parent.mkdir(parents=True, exist_ok=True)
        if link.is_symlink():               # a member named twice: the later one counts, as with extract()
            link.unlink()
        os.symlink(kept, link)
    except OSError:
        if link.is_symlink():               # extract() must not write through a link into the store
            link.unlink()
        return False
    return True


class _Written(Record):
    """An archive this process wrote (or opened before): what it holds, and the file it was written to."""
    def __init__(self, stat: tuple | None, sha256: str | None, files: dict, fmus: dict, validated: bool = True,
                 shape: int | None = None):
        self.stat = stat        # (device, inode, size, mtime, ctime) right after it was written; None: kept in
                                # memory only (not written to disk, see remember_written)
        self.sha256 = sha256    # of the archive's bytes (None: not hashed yet)
        self.files = files      # member name -> bytes (SSD, parameter files; None: a folder)
        self.fmus = fmus        # member name -> (SHA-256, bytes; None: in the store of linked FMUs only)
        self.validated = validated  # the writer validated its SSD (an archive only opened before: not known)
        self.shape = shape      # the writer's number of the SSD's shape (MemoryArchive.shape)


# archives written by this process (master.ssp.writer) by absolute path: a campaign run writes its archive and
# opens it right away, and reading it back meant unpacking and hashing a megabyte of FMUs it had just written.
# The file's identity and times are the key's second half: a file changed or replaced since is read as usual.
_WRITTEN: dict[str, _Written] = {}
_MAX_WRITTEN = 8


def _signature(st: os.stat_result) -> tuple:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def remember_written(path: Path, sha256: str, files: dict, fmus: dict, on_disk: bool = True,
                     shape: int | None = None) -> None:
    """Note the archive just written to ``path`` (its SHA-256 and members; FMU members with their SHA-256).
    ``on_disk`` False: the archive was built for ``path`` but not written there (a campaign run whose folder
    keeps only its summary); this process opens it from memory while no file is at ``path``."""
    if len(_WRITTEN) >= _MAX_WRITTEN:
        _WRITTEN.clear()
    stat = _signature(os.stat(path)) if on_disk else None
    _WRITTEN[os.path.abspath(path)] = _Written(stat, sha256, dict(files), dict(fmus), shape=shape)


def written_here(path: str | os.PathLike) -> bool:
    """Is ``path`` an archive this process wrote (on disk and unchanged since, or kept in memory only)?"""
    return _written(Path(path)) is not None


# archives this process opened (not written) by absolute path: a campaign over one SSP archive opens it for every
# run, and each opening read and hashed its FMUs again to link them.  Kept when every FMU member could be linked
# to the store and the other members are small; keyed by the file's identity and times as _WRITTEN.
_OPENED: dict[str, _Written] = {}
_MAX_REMEMBERED_BYTES = 4 << 20


def _opened(path: Path) -> _Written | None:
    """What this process found in ``path`` when it opened it before, if the file is still that one and its FMUs are
    still in the store."""
    w = _OPENED.get(os.path.abspath(path))
    if w is None or not _unchanged(path, w):
        return None
    store = cache_root() / "archived"
    if not all((store / f"{sha}.fmu").is_file() for sha, _ in w.fmus.values()):
        return None
    return w


def _remember_opened(path: Path, st: os.stat_result, seen: dict) -> None:
    if len(_OPENED) >= _MAX_WRITTEN:
        _OPENED.clear()
    _OPENED[os.path.abspath(path)] = _Written(_signature(st), None, seen["files"], seen["fmus"], validated=False)


def _unchanged(path: Path, w: _Written) -> bool:
    try:
        return _signature(os.stat(path)) == w.stat
    except OSError:
        return False


def _written(path: Path) -> _Written | None:
    """What this process wrote to ``path``, if the file is still the one it wrote (for an archive kept in memory
    only: if no file has been put there since)."""
    w = _WRITTEN.get(os.path.abspath(path))
    if w is None:
        return None
    try:
        now = _signature(os.stat(path))
    except OSError:
        now = None
    return w if now == w.stat else None


# SSD files unpacked from archives this process wrote -> their signature: the writer validated their tree
# against the SSP schema before it serialised it, so reading them need not validate them again
_VALIDATED: dict[str, tuple] = {}


def schema_checked(ssd_path: Path) -> bool:
    """Is ``ssd_path`` an SSD unpacked from an archive this process wrote (and validated), still as written?"""
    sig = _VALIDATED.get(os.path.abspath(ssd_path))
    try:
        return sig is not None and _signature(os.stat(ssd_path)) == sig
    except OSError:
        return False


def _unpack_written(w: _Written) -> Path:
    """The folder that unpacking the archive ``w`` gives (as ``_extract_ssp``), from the members as written."""
    tmp = Path(tempfile.mkdtemp(prefix="cosim-ssp-", dir=UNPACK_DIR))
    try:
        for name, data in w.files.items():
            target = tmp / name
            if data is None:
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
            if name == SSD_NAME and w.validated:
                if len(_VALIDATED) >= _MAX_WRITTEN:
                    _VALIDATED.clear()
                _VALIDATED[os.path.abspath(target)] = _signature(os.stat(target))
        for name, (sha, data) in w.fmus.items():
            target = tmp / name
            if not _place_fmu(sha, lambda out: out.write(data), target):
                if data is None:
                    raise OSError(f"{name} is no longer in the store of linked FMUs")
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise ScenarioError(f"cannot unpack the SSP archive: {exc}", file=tmp) from None
    return tmp


def _from_memory(path: Path, w: _Written) -> ScenarioSource | None:
    """The archive ``w`` that this process wrote, read from its members as written: no folder, no links, the SSD's
    bytes parsed as they are.  None where only an unpacked folder will do: other members than the SSD and the
    FMUs (parameter files, which the parser reads from disk), or an FMU that cannot be put in the store."""
    if set(w.files) != {SSD_NAME}:
        return None
    members = {}
    try:
        for name, (sha, data) in w.fmus.items():
            if data is None:
                return None
            members[name] = _stored_fmu(sha, lambda out, data=data: out.write(data))
    except OSError:
        return None
    memory = MemoryArchive(w.files[SSD_NAME], members, w.validated, w.shape)
    return ScenarioSource(path, path / SSD_NAME, path, memory=memory)


def open_scenario(path: str | os.PathLike, ssd_name: str | None = None, in_memory: bool = False) -> ScenarioSource:
    """Resolve a scenario path; an .ssp archive is unpacked into a temporary folder.  ``in_memory``: an archive
    this process wrote (``remember_written``) is read from memory instead (``ScenarioSource.memory``; only
    ``master.ssp.parser.read_ssd`` reads such a source), even when it was never written to disk."""
    path = Path(path)
    if in_memory and ssd_name in (None, SSD_NAME):
        written = _written(path)
        source = _from_memory(path, written) if written is not None else None
        if source is not None:
            return source
    if not path.exists() and _written(path) is None:        # kept in memory only: unpacked from there below
        raise ScenarioError("scenario not found", file=path)
    if path.is_dir():
        ssd = path / (ssd_name or SSD_NAME)
        if not ssd.is_file():
            raise ScenarioError(f"folder has no {ssd.name}", file=path)
        return ScenarioSource(path, ssd, path)
    if path.suffix.lower() == ".ssd":
        return ScenarioSource(path, path, path.parent)
    written = _written(path) or _opened(path)
    tmp = None
    if written is not None:
        try:
            tmp = _unpack_written(written)
        except ScenarioError:
            if written.validated:
                raise
            _OPENED.pop(os.path.abspath(path), None)       # unpacked from the archive itself below
    if tmp is None:
        st, seen = os.stat(path), {}
        tmp = _extract_ssp(path, seen)
        if seen and _signature(os.stat(path)) == _signature(st):     # not changed while it was read
            _remember_opened(path, st, seen)
    ssd = tmp / (ssd_name or SSD_NAME)
    if not ssd.is_file():
        shutil.rmtree(tmp, ignore_errors=True)
        raise ScenarioError(f"archive has no {ssd.name}", file=path)
    return ScenarioSource(path, ssd, tmp, tmp)


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a scenario file: of an archive this process wrote or opened, known without reading it again."""
    written = _written(Path(path))
    if written is not None:
        return written.sha256
    opened = _OPENED.get(os.path.abspath(path))
    if opened is not None and opened.sha256 is not None and _unchanged(Path(path), opened):
        return opened.sha256
    st = os.stat(path)
    sha = _plain_sha256(path)
    if opened is not None and opened.stat == _signature(st) == _signature(os.stat(path)):
        opened.sha256 = sha
    return sha
