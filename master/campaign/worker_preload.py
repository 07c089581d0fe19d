"""Imported by the campaign's fork server (``pool.PRELOAD``) before it forks any worker: the modules that each
installed scenario kind names in ``ScenarioKind.worker_modules``. A worker forked from the server has them already,
so its first run does not import them (a UAV campaign's worker imported its build, scenario and monitor modules in
its first run: ~1 s of wall at the start of a campaign on a loaded machine, once per worker). The server imports
them while the campaign process reads the campaign file, on a core that would otherwise wait.

A kind that cannot be loaded, or a module that does not import, is skipped here: the first run that needs it says
why, as it would without this preload. Nothing is imported that a worker's run of that kind would not import
itself, before its FMUs load (the kind's own choice of modules)."""
from __future__ import annotations

import importlib
import os

#: set (to "1") in the environment the fork server starts with (``pool._fork_server_started``), and only there: this
#: module imports the kinds' modules when the server imports it, and is inert anywhere else (importing every engine
#: module, tests/master/test_engine_boundary.py, imports no study module)
SERVER_FLAG = "COSIM_MASTER_CAMPAIGN_FORK_SERVER"


def import_worker_modules() -> list[str]:
    """Import every installed scenario kind's ``worker_modules``; returns the names that imported."""
    from ..scenario_kinds import SCENARIO_KINDS
    try:
        kinds = SCENARIO_KINDS.load_all()
    except Exception:   # noqa: BLE001 - a broken plugin is reported by the run that uses it
        return []
    done = []
    for kind in kinds.values():
        for name in getattr(kind, "worker_modules", ()):
            try:
                importlib.import_module(name)
            except Exception:   # noqa: BLE001 - as above
                continue
            done.append(name)
    return done


IMPORTED = import_worker_modules() if os.environ.get(SERVER_FLAG) == "1" else []
