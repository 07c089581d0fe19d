"""Run an SSP with Ecos (via ecospy) as an independent peer master.

``run_ecos(ssp_path, step, n_steps, variables, parameter_set)`` loads the SSP with
``EcosSimulation(ssp_path=..., step_size=step)``, initialises it with the named parameter set, steps it
``n_steps`` times and returns a ``pandas.DataFrame`` with the columns ``time`` (Ecos's clock) and
``"<component>.<variable>"`` for every communication point including t = start.

What Ecos does (ecospy 0.7.2; Ecos-platform/ecos ``src/ecos/simulation.cpp``, ``src/ecos/ssp/ssp.cpp``,
``src/ecos/ssp/ssp_loader.cpp``), and what follows for our SSPs:

* Parameter sets are collected by their ``name`` across all components, and ``init(parameter_set=NAME)``
  applies only the sets of that name (after fmi2EnterInitializationMode); ``init()`` without a name
  applies none.  So an SSP must give every component's set the same name (our UAV builder: "scenario",
  ``uavstudy.build.PARAMETER_SET``).  String parameters are applied like the others.
* Stepping: every instance steps from the same inputs (``std::execution::par``), then all connections
  transfer: Jacobi with zero-order hold, as libcosim and cosim-master's ``jacobi``.
* The clock is a sum: t_{n+1} = t_n + h in double (0.1 s steps give 6.099999999999994 at n = 61), so the
  times passed to fmi2DoStep drift from n * h by rounding; the step size passed is exactly h.
* ``get_real``/``get_integer`` read the last values Ecos fetched (after the step's transfers), as
  ``"instance::variable"``.

The ecospy wheel links libtbb.so.12 without shipping it; the ``tbb`` wheel installs it under
``<prefix>/lib``, which is loaded globally before ecospy is imported.
"""
from __future__ import annotations

import ctypes
import glob
import os
import sys
from typing import Sequence

import pandas as pd


def load_tbb() -> str | None:
    """Load the tbb wheel's libtbb.so.12 (RTLD_GLOBAL) so that ecospy's library resolves it; its path or None."""
    for prefix in dict.fromkeys([sys.prefix, sys.base_prefix]):
        for lib in sorted(glob.glob(os.path.join(prefix, "lib", "libtbb.so.12*"))):
            ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
            return lib
    return None


def ecospy_available() -> bool:
    """ecospy importable here (with the tbb library it needs)."""
    try:
        load_tbb()
        import ecospy  # noqa: F401
    except (ImportError, OSError):
        return False
    return True


def run_ecos(ssp_path, step: float, n_steps: int, variables: Sequence[tuple[str, str, str]],
             parameter_set: str | None) -> pd.DataFrame:
    """Simulate ``ssp_path`` with Ecos for ``n_steps`` steps of ``step`` seconds.

    variables: (component, variable, "Real" | "Integer") to record after initialisation and after every step.
    """
    load_tbb()
    from ecospy import EcosLib, EcosSimulation

    EcosLib.set_log_level("warn")
    sim = EcosSimulation(ssp_path=str(ssp_path), step_size=float(step))
    if sim.init(parameter_set=parameter_set) is False:
        raise RuntimeError("Ecos init failed: " + EcosLib.get_last_error())
    readers = [(f"{c}.{v}", f"{c}::{v}", sim.get_integer if t == "Integer" else sim.get_real)
               for c, v, t in variables]
    rows = []

    def sample():
        rows.append({"time": sim.get_time(), **{key: read(ident) for key, ident, read in readers}})

    sample()
    for _ in range(int(n_steps)):
        sim.step(1)
        sample()
    sim.terminate()
    sim.free()
    return pd.DataFrame(rows)
