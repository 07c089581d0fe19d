"""Run an SSP with OMSimulator (its Python API) as an independent peer master.

``run_omsimulator(ssp_path, step, n_steps, variables)`` instantiates the SSP with ``OMSimulator.SSP``, sets the
fixed step, initialises, steps ``n_steps`` times and returns a ``pandas.DataFrame`` with the columns
``time`` (OMSimulator's clock) and ``"<component>.<variable>"`` after initialisation and after every step.

OMSimulator is not installed from a registry (its package downloads binaries at build time); a build is kept in
``<repo>/../shared/omsimulator`` (its README), found by ``omsimulator_lib()``: ``$COSIM_OMSIMULATOR_LIB`` or that
folder's ``lib/``.  Its library must be loaded in the process that imports it, so the tests run this module in a
child process (a failing FMU can abort OMSimulator, which then takes the process with it).

What OMSimulator does (commit 2940ef11; src/OMSimulatorLib/SystemWC.cpp, ComponentFMUCS.cpp), and what
follows for our SSPs:

* A system of co-simulation FMUs is a "weakly coupled" system (``SystemWC``) with the solver ``oms_ma``: every
  component steps from the same inputs, then every connection is transferred in the order of the dependency
  graph of the FMUs' ``ModelStructure`` (outputs to inputs; an algebraic loop is solved by iteration).  With no
  direct feedthrough this is Jacobi with zero-order hold, as cosim-master's ``jacobi``, libcosim and Ecos.
  ``oms_ma`` extrapolates inputs only with the flag ``--inputExtrapolation`` (not set here).
* The system clock is a sum, t_{n+1} = t_n + h, clamped to the stop time; each FMU is stepped by its own
  clock to the system's: fmi2DoStep(t_c, (t_{n+1}) - t_c), so the step size passed differs from h by the
  rounding of t + h - t (a few ulps of t); a run to the stop time ends with one step of the remainder
  (1.95e-14 s for 10 s at 0.1 s).
* The initialisation graph is built from ``InitialUnknowns``; an output without ``dependencies`` depends on
  every input, so FMUs that declare none form an algebraic loop there, which its solver cannot take through an
  Integer ("[getReal] Unknown signal").
* Parameter values of the SSD (every parameter set, whatever its name) are set before instantiation.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Sequence

import pandas as pd

ENV = "COSIM_OMSIMULATOR_LIB"


def omsimulator_lib(repo: Path | str) -> Path | None:
    """The folder holding OMSimulator's Python package and library: $COSIM_OMSIMULATOR_LIB, else
    <repo>/../shared/omsimulator/lib; None where neither holds it."""
    for folder in (os.environ.get(ENV), Path(repo) / ".." / "shared" / "omsimulator" / "lib"):
        if folder and (Path(folder) / "OMSimulator" / "__init__.py").is_file() \
                and (Path(folder) / "libOMSimulator.so").is_file():
            return Path(folder).resolve()
    return None


def string_parameters(ssp_path) -> list[tuple[str, str, str]]:
    """(component, parameter, value) of every String value in the SSD's inline parameter sets."""
    import zipfile

    from lxml import etree

    ssv = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
    ssd = "http://ssp-standard.org/SSP1/SystemStructureDescription"
    with zipfile.ZipFile(ssp_path) as z:
        root = etree.fromstring(z.read("SystemStructure.ssd"))
    out = []
    for comp in root.iter(f"{{{ssd}}}Component"):
        for par in comp.iter(f"{{{ssv}}}Parameter"):
            value = par.find(f"{{{ssv}}}String")
            if value is not None:
                out.append((comp.get("name"), par.get("name"), value.get("value")))
    return out


def run_omsimulator(ssp_path, step: float, n_steps: int, variables: Sequence[tuple[str, str]],
                    lib: Path | str | None = None, set_strings: bool = False) -> pd.DataFrame:
    """Simulate ``ssp_path`` in OMSimulator for ``n_steps`` fixed steps of ``step`` seconds (oms_ma).

    variables: (component, variable) to record (Real, Integer or Boolean), read through the API with full
    precision after initialisation and after every step.  The stop time is set half a step past the last
    communication point, so that no step is shortened to it.
    """
    if lib is not None and str(lib) not in sys.path:
        sys.path.insert(0, str(lib))
    from OMSimulator import SSP, Capi
    from OMSimulator.variable import SignalType

    model = SSP(str(ssp_path)).instantiate()
    system = model.system.name
    if set_strings:     # what OMSimulator drops (module docstring): set through the API once instantiated
        for comp, name, value in string_parameters(ssp_path):
            if Capi.setString(f"{model.mappedCrefs[f'{system}.{comp}']}.{name}", value).name != "ok":
                raise RuntimeError(f"OMSimulator could not set {comp}.{name}")
    model.setResultFile("")                       # no result file in the working directory
    model.setFixedStepSize(float(step))
    model.setStopTime((int(n_steps) + 0.5) * float(step))
    readers = []
    for comp, var in variables:
        cref = f"{model.mappedCrefs[f'{system}.{comp}']}.{var}"
        kind, status = Capi.getVariableType(cref)
        if status.name != "ok":
            raise KeyError(f"OMSimulator has no variable {comp}.{var} ({cref})")
        read = {SignalType.Real: Capi.getReal, SignalType.Integer: Capi.getInteger,
                SignalType.Boolean: Capi.getBoolean}[SignalType(kind)]
        readers.append((f"{comp}.{var}", cref, read))
    rows = []

    def sample():
        rows.append({"time": model.getTime(), **{key: read(cref)[0] for key, cref, read in readers}})

    model.initialize()
    sample()
    for _ in range(int(n_steps)):
        # stepUntil, not doStep: it first transfers the outputs to the inputs, which the initialisation did before
        # exitInitializationMode only; half a step ahead is one step of its summed clock, whatever its rounding
        model.stepUntil(model.getTime() + 0.5 * float(step))
        sample()
    model.terminate()
    model.delete()
    return pd.DataFrame(rows)
