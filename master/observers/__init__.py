"""Observers see the system between steps: recording, monitors, (later) live streams.

Life cycle (driven by :class:`master.execution.Execution`): ``required_variables`` / ``sampled_variables``
before instantiation (what the master must read for them), ``attach`` after initialization, ``after_step``
after every master step, ``finish`` once at the end, also after a failure.
"""
from .base import Observer, ObserverContext

__all__ = ["Observer", "ObserverContext"]
