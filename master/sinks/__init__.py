"""Output sinks: where recorded blocks of rows go (Parquet, CSV, memory, ...), in one registry.

A sink receives the schema once and then whole blocks as ``pyarrow.Table`` objects; each module of this
folder registers its sink when imported, so a new output format is one file (``@SINKS.register("name")``);
other packages publish theirs under the ``cosim_master.sinks`` entry point group.
"""
from ..registry import Registry, import_submodules
from .base import Sink

SINKS: Registry[type[Sink]] = Registry("sink", "cosim_master.sinks", builtins=import_submodules(__name__))

__all__ = ["SINKS", "Sink"]
