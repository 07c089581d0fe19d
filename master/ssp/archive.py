"""Locating the SystemStructure.ssd of a scenario given as .ssp archive, folder or bare .ssd."""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import ScenarioError

SSD_NAME = "SystemStructure.ssd"


@dataclass
class ScenarioSource:
    path: Path          # what the user named
    ssd_path: Path      # the SSD file on disk
    root: Path          # folder that component sources are relative to
    tempdir: Path | None = None

    @property
    def shown_root(self) -> str:
        """How files inside the scenario are named in messages: under the archive's or folder's name; files
        next to a bare .ssd keep their own paths."""
        return str(self.path) if self.tempdir is not None or self.root == self.path else ""

    def close(self) -> None:
        if self.tempdir is not None:
            shutil.rmtree(self.tempdir, ignore_errors=True)
            self.tempdir = None


def _extract_ssp(path: Path) -> Path:
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        _not_an_ssp(path)
        raise ScenarioError(f"not a readable SSP archive (zip): {exc}", file=path) from None
    with zf:
        names = zf.namelist()
        if SSD_NAME not in names:
            raise ScenarioError(f"archive has no {SSD_NAME} at its top level", file=path)
        tmp = Path(tempfile.mkdtemp(prefix="cosim-ssp-"))
        for name in names:
            target = (tmp / name).resolve()
            if not str(target).startswith(str(tmp.resolve()) + os.sep) and target != tmp.resolve():
                shutil.rmtree(tmp, ignore_errors=True)
                raise ScenarioError(f"archive member escapes the archive: {name}", file=path)
        try:
            for info in zf.infolist():
                if info.is_dir() or not info.filename.lower().endswith(".fmu") or not _link_fmu(zf, info, tmp):
                    zf.extract(info, tmp)
        except (zipfile.BadZipFile, OSError, EOFError) as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            raise ScenarioError(f"corrupt SSP archive: {exc}", file=path) from None
    return tmp


def _link_fmu(zf: zipfile.ZipFile, info: zipfile.ZipInfo, tmp: Path) -> bool:
    """Put an FMU member in place as a link to one copy per content (``<FMU cache>/archived/<sha256>.fmu``)
    instead of a fresh file: a campaign unpacks the same FMUs from every run's archive, and the FMU cache
    (``master.fmi.cache``) knows a file it has hashed by its path and mtime, so it neither hashes nor unpacks the
    FMU again.  False (extract it as usual) where links cannot be made."""
    from ..fmi.cache import cache_root
    h = hashlib.sha256()
    with zf.open(info) as fh:            # reading to the end checks the member's CRC, as extract() does
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    sha = h.hexdigest()
    store = cache_root() / "archived"
    kept = store / f"{sha}.fmu"
    link = tmp / info.filename
    try:
        if not kept.is_file():
            store.mkdir(parents=True, exist_ok=True)
            part = store / f".{sha}.{os.getpid()}.tmp"
            with zf.open(info) as fh, open(part, "wb") as out:
                shutil.copyfileobj(fh, out, 1 << 20)
            os.replace(part, kept)          # whole or absent, whichever process wins
        link.parent.mkdir(parents=True, exist_ok=True)
        if link.is_symlink():               # a member named twice: the later one counts, as with extract()
            link.unlink()
        os.symlink(kept, link)
    except OSError:
        if link.is_symlink():               # extract() must not write through a link into the store
            link.unlink()
        return False
    return True


def _not_an_ssp(path: Path) -> None:
    """A scenario of another kind (a study's YAML) is built into an SSP first: say how."""
    from ..scenario_kinds import kind_claiming
    try:
        kind = kind_claiming(path)
    except Exception:   # noqa: BLE001 - only a better message is at stake here
        return
    if kind is not None and kind.name != "ssp":
        raise ScenarioError(f"this is a {kind.label} scenario, not an SSP: build one with `cosim-master build-scenario "
                            f"{path} -o scenario.ssp` and run that", file=path)


def open_scenario(path: str | os.PathLike, ssd_name: str | None = None) -> ScenarioSource:
    """Resolve a scenario path; an .ssp archive is unpacked into a temporary folder."""
    path = Path(path)
    if not path.exists():
        raise ScenarioError("scenario not found", file=path)
    if path.is_dir():
        ssd = path / (ssd_name or SSD_NAME)
        if not ssd.is_file():
            raise ScenarioError(f"folder has no {ssd.name}", file=path)
        return ScenarioSource(path, ssd, path)
    if path.suffix.lower() == ".ssd":
        return ScenarioSource(path, path, path.parent)
    tmp = _extract_ssp(path)
    ssd = tmp / (ssd_name or SSD_NAME)
    if not ssd.is_file():
        shutil.rmtree(tmp, ignore_errors=True)
        raise ScenarioError(f"archive has no {ssd.name}", file=path)
    return ScenarioSource(path, ssd, tmp, tmp)


def file_sha256(path: str | os.PathLike) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
