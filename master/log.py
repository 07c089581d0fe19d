"""The engine's warnings, on the logger ``cosim_master``: ``warning(...)`` imports ``logging`` when a warning is
given. A run that warns of nothing, most runs, never imports it: with the ``string`` and ``traceback`` modules it
brings that was ~12 M instructions (~1.7 %) of a short run's start-up, paid in the simulation process.

``when_first_used(setup)``: ``setup(logger)`` is called when the logger is first needed in this process, or at once
if ``logging`` is already imported (its user may have set it up); the command line installs its line format so. Code
that logs to ``cosim_master`` through ``logging`` itself calls ``logger()`` first (``live.open_streams`` does, for
the live streams' modules)."""
from __future__ import annotations

import sys

NAME = "cosim_master"
_setups: list = []      # what waits for the logger's first use, in order


def logger():
    """The engine's logger, set up as asked (``when_first_used``)."""
    import logging
    log = logging.getLogger(NAME)
    while _setups:
        _setups.pop(0)(log)
    return log


def warning(msg: str, *args) -> None:
    logger().warning(msg, *args)


def when_first_used(setup) -> None:
    _setups.append(setup)
    if "logging" in sys.modules:
        logger()


def forget(setup) -> None:
    """``setup`` is no longer wanted (the logger was not used meanwhile)."""
    if setup in _setups:
        _setups.remove(setup)
