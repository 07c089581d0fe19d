"""A bare ``.fmu`` run or inspected as what it is to the master: an SSP of one component.

FMPy, OMSimulator and libcosim's ``cosim run-single`` run one FMU directly; here the FMU becomes an in-memory
one-component system (``ssp.writer.one_fmu_system``), so everything a run does for an SSP (``--input``,
``--param``, ``--record``, the default experiment, supervision, run.json) holds for it unchanged.
"""
from __future__ import annotations

from pathlib import Path


def is_bare_fmu(scenario) -> bool:
    """A path naming an FMU archive (not an SSP folder that happens to end in .fmu)."""
    path = Path(scenario)
    return path.suffix.lower() == ".fmu" and not path.is_dir()


def bare_fmu_scenario(fmu: Path) -> Path:
    """The in-memory SSP of ``fmu`` as its one component (named as the file's stem): nothing is written to disk."""
    from ..ssp.writer import one_fmu_system     # here: every run asks is_bare_fmu, few need the SSP writer
    return one_fmu_system(Path(fmu)).in_memory()
