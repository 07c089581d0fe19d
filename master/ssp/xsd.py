"""Validation of SSP files against the official SSP 1.0 XSD schemas shipped with fmpy."""
from __future__ import annotations

import functools
import os
from pathlib import Path

from lxml import etree

from ..errors import ScenarioError

_SCHEMAS = {
    "ssd": "SystemStructureDescription.xsd",
    "ssv": "SystemStructureParameterValues.xsd",
    "ssm": "SystemStructureParameterMapping.xsd",
    "ssb": "SystemStructureSignalDictionary.xsd",
}


def _schema_dir() -> Path:
    import fmpy
    return Path(os.path.dirname(fmpy.__file__)) / "ssp" / "schema"


@functools.lru_cache(maxsize=None)
def _schema(kind: str) -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(_schema_dir() / _SCHEMAS[kind])))


def parse_xml(path: Path, shown_as: str | None = None, data: bytes | None = None) -> etree._ElementTree:
    """Parse an XML file (``data``: its bytes, already read; ``path`` is then its name only); syntax errors become a
    one-line ScenarioError with the line."""
    parser = etree.XMLParser(remove_blank_text=False, resolve_entities=False)
    try:
        if data is not None:
            return etree.fromstring(data, parser, base_url=str(path)).getroottree()
        return etree.parse(str(path), parser)
    except OSError as exc:
        raise ScenarioError(f"cannot read: {exc}", file=shown_as or path) from None
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno else None
        raise ScenarioError(f"invalid XML: {exc.msg}", file=shown_as or path, line=line) from None


def read_bytes(path: Path, shown_as: str | None = None) -> bytes:
    """The file's bytes, for ``parse_xml(data=...)`` and ``validate(source=...)``; an unreadable file is the same
    one-line error as in ``parse_xml``."""
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise ScenarioError(f"cannot read: {exc}", file=shown_as or path) from None


def _passed_record(kind: str, source: bytes):
    """The record that a document of exactly these bytes passed this schema: keyed by the bytes, the kind, fmpy's
    version (whose files the schemas are) and libxml2's (which applies them)."""
    from ..cache_paths import ValidationRecord, fmpy_validator
    return ValidationRecord(f"ssp 1 {kind} ".encode() + fmpy_validator(), source)


def validate(tree: etree._ElementTree, kind: str, shown_as: str, source: bytes | None = None) -> None:
    """Validate against the SSP 1.0 schema; documents of SSP 2.0 are parsed without XSD (none is shipped).
    ``source``: the bytes ``tree`` was parsed from; a document of the same bytes that passed before (in any
    process: a record in the cache folder) is not validated again. Building the schema is most of the cost of
    validating a small SSD (~1-2 ms a process, more on a busy machine), paid by every run."""
    version = tree.getroot().get("version", "1.0")
    if not version.startswith("1."):
        return
    record = _passed_record(kind, source) if source is not None else None
    if record is not None and record.passed():
        return
    schema = _schema(kind)
    if not schema.validate(tree):
        err = schema.error_log.last_error
        for e in schema.error_log:   # the first error is the cause, later ones are consequences
            err = e
            break
        msg = err.message.replace("{http://ssp-standard.org/SSP1/SystemStructureDescription}", "ssd:")
        msg = msg.replace("{http://ssp-standard.org/SSP1/SystemStructureCommon}", "ssc:")
        msg = msg.replace("{http://ssp-standard.org/SSP1/SystemStructureParameterValues}", "ssv:")
        msg = msg.replace("{http://ssp-standard.org/SSP1/SystemStructureParameterMapping}", "ssm:")
        raise ScenarioError(f"does not conform to the SSP schema: {msg}", file=shown_as, line=err.line)
    if record is not None:
        record.remember()
