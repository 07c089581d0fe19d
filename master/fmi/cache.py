"""Each FMU archive is unpacked once (keyed by its SHA-256) and its description read once per process.

The unpacked tree lives in a user cache folder so that repeated runs and campaigns skip the
extraction; every instance of the same FMU shares it.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from ..cache_paths import ValidationRecord, cache_root, file_sha256, fmpy_validator
from ..errors import FmuError
from ..log import warning
from ..records import Record

#: the kind of a table component (fmi/table.py), in place of an FMU's "CoSimulation" / "ModelExchange"
CSV_KIND = "CsvSource"


class LoadedFmu(Record):
    """An FMU read and unpacked. A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, path: Path, sha256: str, unzip_dir: Path, md, kind: str | None = None):
        self.path, self.sha256, self.unzip_dir = path, sha256, unzip_dir
        self.md = md                # fmpy ModelDescription
        self.kind = kind            # the FMI kind a component runs it as (set per component by plan.build_plan)

    def as_kind(self, kind: str | None) -> "LoadedFmu":
        """The same FMU, run as ``kind``."""
        return LoadedFmu(self.path, self.sha256, self.unzip_dir, self.md, kind)

    @property
    def fmi_version(self) -> str:
        return self.md.fmiVersion


_by_stat: dict[tuple, str] = {}
_by_hash: dict[tuple[str, bool], LoadedFmu] = {}     # (SHA-256, lenient) -> the FMU read that way


def _extract(path: Path, sha: str, shown_as: str) -> Path:
    root = cache_root()
    target = root / sha
    if (target / "modelDescription.xml").is_file():
        return target
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{sha[:12]}-", dir=root))
    try:
        with zipfile.ZipFile(path) as zf:
            zf.extractall(tmp)
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise FmuError(f"not a readable FMU archive: {exc}", file=shown_as) from None
    if not (tmp / "modelDescription.xml").is_file():
        shutil.rmtree(tmp, ignore_errors=True)
        raise FmuError("FMU archive has no modelDescription.xml", file=shown_as)
    try:
        os.rename(tmp, target)
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)   # another process won the race; its copy is identical
    return target


def load_fmu(path: str | os.PathLike, shown_as: str | None = None, lenient: bool = False) -> LoadedFmu:
    """Unpack (once) and read the model description of an FMU. ``lenient``: a modelDescription.xml that
    breaks the schema or the standard's rules is accepted when the master can still use it; what was
    tolerated is logged as warnings (``cosim_master`` logger)."""
    path = Path(path)
    shown_as = shown_as or str(path)
    try:
        st = path.stat()
    except OSError as exc:
        raise FmuError(f"cannot read FMU: {exc.strerror}", file=shown_as) from None
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    sha = _by_stat.get(key)
    if sha is None:
        sha = file_sha256(path)
        _by_stat[key] = sha
    loaded = _by_hash.get((sha, lenient))
    if loaded is not None:
        return loaded if loaded.path == path else LoadedFmu(path, sha, loaded.unzip_dir, loaded.md)
    unzip_dir = _extract(path, sha, shown_as)
    md = _read_description(unzip_dir, shown_as, lenient)
    if md.fmiVersion == "1.0":
        _add_fmi1_outputs(md, unzip_dir)
    loaded = LoadedFmu(path, sha, unzip_dir, md)
    _by_hash[(sha, lenient)] = loaded
    return loaded


def _read_description(unzip_dir: Path, shown_as: str, lenient: bool):
    from fmpy import read_model_description
    record = _validation_record(unzip_dir)
    if record is not None and record.passed():     # these very bytes passed this very validation before
        return read_model_description(str(unzip_dir), validate=False)
    try:
        md = read_model_description(str(unzip_dir), validate=True)
    except Exception as exc:  # fmpy raises bare Exceptions with the schema message
        reason = " ".join(str(exc).split())
    else:
        if record is not None:
            record.remember()
        return md
    if not lenient:
        raise FmuError(f"invalid modelDescription.xml: {reason}", file=shown_as)
    warning("%s: modelDescription.xml is not valid (%s); read anyway (lenient)", shown_as, reason)
    try:
        md = read_model_description(str(unzip_dir), validate=False)
    except Exception as exc:
        raise FmuError(f"unreadable modelDescription.xml: {' '.join(str(exc).split())}", file=shown_as) from None
    for problem in _usability_problems(md):
        warning("%s: %s", shown_as, problem)
    return md


#: the files fmpy's validation reads in an unpacked FMU (a missing one counts as missing)
_VALIDATED_FILES = ("modelDescription.xml", "sources/buildDescription.xml")


def _validation_record(unzip_dir: Path) -> ValidationRecord | None:
    """The record of fmpy's validation (its schema and its own rules) of these description files: keyed by their
    bytes, fmpy's version (its schemas and rules) and libxml2's (which applies the schema). Building fmpy's schema
    is most of a small FMU's validation (~5 ms a process), paid again by every run. None: the files cannot be read
    here (then they are validated as before)."""
    parts = [fmpy_validator()]
    try:
        for name in _VALIDATED_FILES:
            try:
                parts.append(b"present" + (unzip_dir / name).read_bytes())
            except FileNotFoundError:
                parts.append(b"missing")
    except OSError:
        return None
    return ValidationRecord(*parts)


def _add_fmi1_outputs(md, unzip_dir: Path) -> None:
    """FMI 1.0 has no ModelStructure, so fmpy leaves ``md.outputs`` empty; the outputs and their DirectDependency
    (the inputs an output depends on directly; without the element: every input) are read here, so that the
    master orders FMI 1.0 components as it does FMI 2.0 ones."""
    from xml.etree import ElementTree

    from fmpy.model_description import Unknown
    by_name = {v.name: v for v in md.modelVariables}
    root = ElementTree.parse(unzip_dir / "modelDescription.xml").getroot()
    for sv in root.iterfind("ModelVariables/ScalarVariable"):
        if sv.get("causality") != "output" or sv.get("name") not in by_name:
            continue
        unknown = Unknown()
        unknown.variable = by_name[sv.get("name")]
        direct = sv.find("DirectDependency")
        if direct is not None:
            names = (n.text.strip() for n in direct.iterfind("Name"))
            unknown.dependencies = [by_name[name] for name in names if name in by_name]
        md.outputs.append(unknown)


def _usability_problems(md) -> list[str]:
    """What a lenient read lets through that changes what the master does with the FMU."""
    by_name: dict[str, list[int]] = {}
    for v in md.modelVariables:
        by_name.setdefault(v.name, []).append(int(v.valueReference))
    return [f"variable {name!r} is declared {len(vrs)} times (value references {', '.join(map(str, vrs))}); "
            "the SSD's connectors and parameters reach the last of them"
            for name, vrs in by_name.items() if len(vrs) > 1]
