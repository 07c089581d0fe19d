"""Which slave class runs a component: the one place that decides."""
from __future__ import annotations

from .cache import LoadedFmu
from .logsink import LogSink
from .slave import Slave


def slave_class(fmu: LoadedFmu, inprocess: bool = True) -> type[Slave]:
    """Co-simulation is preferred when the FMU offers both kinds; pythonfmu FMUs run in process (their slave
    class called directly, bit-identical to their binary) unless ``inprocess`` is false."""
    md = fmu.md
    if md.coSimulation is None and md.modelExchange is not None:
        from .model_exchange import Fmi2MeSlave
        return Fmi2MeSlave
    if fmu.fmi_version.startswith("3"):
        from .fmi3 import Fmi3Slave
        return Fmi3Slave
    if inprocess:
        from .inprocess import PythonFmuSlave, is_pythonfmu
        if is_pythonfmu(fmu):
            return PythonFmuSlave
    from .fmi2 import Fmi2Slave
    return Fmi2Slave


def make_slave(name: str, fmu: LoadedFmu, log: LogSink, shown_as: str, *, logging_on: bool = False,
               inprocess: bool = True) -> Slave:
    cls = slave_class(fmu, inprocess)
    from .inprocess import PythonFmuSlave
    if cls is PythonFmuSlave:
        return cls(name, fmu, log, shown_as)
    return cls(name, fmu, log, shown_as, logging_on)
