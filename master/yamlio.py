"""YAML in and out through libyaml when PyYAML was built with it: about ten times faster than the
pure-Python parser and emitter, which matters when a campaign reads and writes a scenario per run.
Same documents, same Python types, same exception (``yaml.YAMLError`` with ``problem_mark``)."""
from __future__ import annotations

import yaml

_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def load(text):
    """``yaml.safe_load``."""
    return yaml.load(text, Loader=_LOADER)


def dump(data, **options) -> str:
    """``yaml.safe_dump`` (to a string)."""
    return yaml.dump(data, Dumper=_DUMPER, **options)
