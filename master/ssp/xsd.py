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


def validate(tree: etree._ElementTree, kind: str, shown_as: str) -> None:
    """Validate against the SSP 1.0 schema; documents of SSP 2.0 are parsed without XSD (none is shipped)."""
    version = tree.getroot().get("version", "1.0")
    if not version.startswith("1."):
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
