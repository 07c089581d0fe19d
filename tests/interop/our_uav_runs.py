"""cosim-master's own run of the shipped one-UAV mission (ssp/paper_free_1uav_B.ssp, jacobi, 0.1 s, to its end at
825.1 s), which three interop modules compare with a peer flying the whole mission (Ecos, libcosim, OMSimulator):
the same run with the same arguments, run once a session instead of once a module (~0.8 s of CPU each).

It records the union of the variables the modules compare, and each module takes its own columns.  Recording more
variables changes no value: the recorder reads outputs after each step and sets nothing, and the run is
deterministic.  Checked when this was written: each module's columns, dtypes included, are bit for bit those of a
run recording only them.
"""
from __future__ import annotations

import functools

import pandas as pd
from peer_runs import SSP_DIR

import master

FREE_1UAV = SSP_DIR / "paper_free_1uav_B.ssp"
STEP = 0.1
#: what test_uav_ecos, test_uav_libcosim and test_uav_omsimulator compare of the whole mission
FREE_1UAV_RECORD = ["uav1_dyn.x", "uav1_dyn.y", "uav1_dyn.z", "uav1_dyn.phase", "uav1_bat.soc", "uav1_strat.cmd",
                    "uav1_strat.mission_state", "uav1_strat.photo_count", "uav1_strat.last_photo_target",
                    "wind.wind_x", "wind.wind_level"]


@functools.lru_cache(maxsize=None)
def _whole_free_1uav_mission() -> pd.DataFrame:
    return master.run(FREE_1UAV, output=None, algorithm="jacobi", step=STEP, record_interval=STEP,
                      record=FREE_1UAV_RECORD).frame


def whole_free_1uav_mission(record: list[str]) -> pd.DataFrame:
    """Our run of the whole shipped mission, ``time`` and the ``record`` columns (a subset of FREE_1UAV_RECORD)."""
    missing = sorted(set(record) - set(FREE_1UAV_RECORD))
    assert not missing, f"add {missing} to our_uav_runs.FREE_1UAV_RECORD"
    return _whole_free_1uav_mission()[["time", *record]]
