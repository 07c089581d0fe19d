"""Which slave class runs a component: the one place that decides."""
from __future__ import annotations

import sys

from .cache import CSV_KIND, LoadedFmu
from .logsink import LogSink
from .slave import Slave

# what a component may ask for (the SSP Component's implementation attribute)
IMPLEMENTATIONS = ("any", "ModelExchange", "CoSimulation")


def choose_kind(fmu: LoadedFmu, implementation: str = "any") -> str:
    """The FMI kind ("CoSimulation" or "ModelExchange") a component runs its FMU as: the one asked for, or
    co-simulation when the FMU offers both. A ValueError says why the FMU cannot run as asked."""
    md = fmu.md
    offered = [k for k, part in (("CoSimulation", md.coSimulation), ("ModelExchange", md.modelExchange)) if part]
    if implementation not in IMPLEMENTATIONS:
        raise ValueError(f"implementation {implementation!r} is not one of {', '.join(IMPLEMENTATIONS)}")
    if not offered:
        if getattr(md, "scheduledExecution", None) is not None:
            raise ValueError("the FMU offers FMI 3.0 scheduled execution only (model partitions activated by "
                             "Clocks), which is not supported: only co-simulation and model exchange are")
        raise ValueError("the FMU supports neither co-simulation nor model exchange")
    wanted = offered[0] if implementation == "any" else implementation
    if wanted not in offered:
        raise ValueError(f"implementation {implementation} is asked for, but the FMU offers {offered[0]} only")
    if wanted == "ModelExchange" and fmu.fmi_version.startswith("1"):
        raise ValueError("FMI 1.0 model exchange is not supported (FMI 1.0 co-simulation is)")
    return wanted


def slave_class(fmu: LoadedFmu, inprocess: bool = True, implementation: str | None = None) -> type[Slave]:
    """The class for the kind chosen by :func:`choose_kind` (``implementation`` None: the kind the plan chose
    for the component, ``fmu.kind``); pythonfmu FMUs run in process (their slave class called directly,
    bit-identical to their binary) unless ``inprocess`` is false. An input table (no FMU) is a CSV source."""
    if fmu.kind == CSV_KIND:
        from .table import CsvSourceSlave       # (with the csv module: a run without input tables needs neither)
        return CsvSourceSlave
    if choose_kind(fmu, implementation or fmu.kind or "any") == "ModelExchange":
        if fmu.fmi_version.startswith("3"):
            from .model_exchange3 import Fmi3MeSlave
            return Fmi3MeSlave
        from .model_exchange import Fmi2MeSlave
        return Fmi2MeSlave
    if fmu.fmi_version.startswith("3"):
        from .fmi3 import Fmi3Slave
        return Fmi3Slave
    if fmu.fmi_version.startswith("1"):
        from .fmi1 import Fmi1Slave
        return Fmi1Slave
    if inprocess:
        from .inprocess_import import is_pythonfmu
        if is_pythonfmu(fmu):
            from .inprocess import PythonFmuSlave       # (its life cycle: only a pythonfmu FMU's run imports it)
            return PythonFmuSlave
    from .fmi2 import Fmi2Slave
    return Fmi2Slave


def make_slave(name: str, fmu: LoadedFmu, log: LogSink, shown_as: str, *, logging_on: bool = False,
               inprocess: bool = True, implementation: str | None = None, solver=None) -> Slave:
    """``solver``: an ode_solvers.SolverChoice for a model-exchange component (None: the default)."""
    cls = slave_class(fmu, inprocess, implementation)
    inprocess_module = sys.modules.get(f"{__package__}.inprocess")       # imported if cls is its slave
    if inprocess_module is not None and cls is inprocess_module.PythonFmuSlave:
        return cls(name, fmu, log, shown_as)
    if cls.kind == "ModelExchange":
        return cls(name, fmu, log, shown_as, logging_on, solver=solver)
    return cls(name, fmu, log, shown_as, logging_on)
