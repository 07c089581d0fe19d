"""YAML in and out through libyaml when PyYAML was built with it: about ten times faster than the
pure-Python parser and emitter, which matters when a campaign reads and writes a scenario per run.
Same documents, same Python types, same exception (``yaml.YAMLError`` with ``problem_mark``).

Unlike ``yaml.safe_load``, a mapping holding the same key twice is an error: PyYAML silently keeps the last
value, so a scenario or campaign file with ``n_uavs`` written twice would run with whichever came last."""
from __future__ import annotations

import re

import yaml
from yaml.constructor import ConstructorError

from .errors import ScenarioError

MERGE_TAG = "tag:yaml.org,2002:merge"


class _UniqueKeys:
    """Constructor mixin refusing a mapping that holds the same key twice (file line and key in the error)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            _refuse_duplicate_keys(self, node)
        return super().construct_mapping(node, deep=deep)


def _refuse_duplicate_keys(constructor, node: yaml.MappingNode) -> None:
    first_line: dict = {}
    for key_node, _ in node.value:
        if key_node.tag == MERGE_TAG:     # ``<<: *base`` merges may be overridden: that is what they are for
            continue
        key = constructor.construct_object(key_node, deep=True)
        try:
            seen = first_line.get(key)
        except TypeError:                 # an unhashable key: the base constructor says so
            continue
        if seen is not None:
            raise ConstructorError("while constructing a mapping", node.start_mark,
                                   f"duplicate key {key!r} (first at line {seen})", key_node.start_mark)
        first_line[key] = key_node.start_mark.line + 1


class PySafeLoader(_UniqueKeys, yaml.SafeLoader):
    """``yaml.SafeLoader`` refusing duplicate keys."""


if hasattr(yaml, "CSafeLoader"):
    class CSafeLoader(_UniqueKeys, yaml.CSafeLoader):
        """``yaml.CSafeLoader`` (libyaml's parser, PyYAML's constructor) refusing duplicate keys."""
    _LOADER = CSafeLoader
else:                                     # pragma: no cover - PyYAML built without libyaml
    _LOADER = PySafeLoader
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)

# YAML 1.1 (PyYAML's rule) reads a float only with a dot, so `step: 5e-05` or `1e3` written by hand became a string
# and failed as "expected a positive number"; YAML 1.2 and every other reader take them as numbers.
_EXPONENT_FLOAT = re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")
for _loader in {PySafeLoader, _LOADER}:
    _loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789"))


def load(text):
    """``yaml.safe_load``, refusing duplicate keys."""
    return yaml.load(text, Loader=_LOADER)


def load_text(text, file):
    """:func:`load`; invalid YAML is a one-line :class:`ScenarioError` naming ``file`` and the line."""
    try:
        return load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise ScenarioError(f"invalid YAML: {getattr(exc, 'problem', None) or exc}", file=str(file),
                            element=f"line {mark.line + 1}" if mark is not None else "yaml") from None


def dump(data, **options) -> str:
    """``yaml.safe_dump`` (to a string)."""
    return yaml.dump(data, Dumper=_DUMPER, **options)
