"""Output sinks: where recorded blocks of rows go (Parquet, CSV, memory, ...), in one registry.

A sink receives the schema once and then whole blocks as ``pyarrow.Table`` objects; each module of this
folder registers its sink when imported (``@SINKS.register("name")``), and ``BUILTIN_SINKS`` names that module, so
that a run imports only the sinks it writes to, and a supervised run imports them (and pyarrow with them) in its
supervising process only, once the simulation process has started (master/supervise.py); other packages publish
theirs under the ``cosim_master.sinks`` entry point group.
"""
from ..registry import Registry
from .base import Sink

BUILTIN_SINKS = {"csv": "master.sinks.csv", "memory": "master.sinks.memory", "parquet": "master.sinks.parquet"}
SINKS: Registry[type[Sink]] = Registry("sink", "cosim_master.sinks", builtins=BUILTIN_SINKS)

__all__ = ["BUILTIN_SINKS", "SINKS", "Sink"]
