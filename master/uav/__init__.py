"""The multi-UAV surveillance study on top of the master.

* :mod:`master.uav.build` -- scenario YAML (or the paper's configuration folder) -> SSP archive;
* :mod:`master.monitors.uav` -- the UAV monitor plugin (collisions, zones, mission events);
* :mod:`master.uav.outputs` -- trajectory, photos, summary and map written after a run.
"""
from __future__ import annotations

__all__ = ["build_scenario", "build_from_paper_config", "build_ssp", "default_fmu_dir"]


def __getattr__(name):  # lazy: importing master.uav must not pull in lxml/fmpy
    if name in __all__:
        from . import build
        return getattr(build, name)
    raise AttributeError(name)
