"""The flattened system a scenario describes, independent of the XML it came from."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..units import Unit

# SSP connector type names mapped to the four FMI 2.0 base types the master moves around.
SSP_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration", "Binary")
# the component type of an input table (OMSimulator's convention): a CSV file whose columns drive inputs
CSV_SOURCE_TYPE = "text/csv"


@dataclass
class Connector:
    name: str
    kind: str                 # input, output, parameter, calculatedParameter, inout
    type: str | None = None   # one of SSP_TYPES, None when the SSD leaves it to the FMU
    unit: str | None = None
    line: int | None = None


@dataclass
class Component:
    name: str                 # flattened, dotted path for components of nested systems
    source: str               # as written in the SSD
    fmu_path: Path            # resolved on disk
    type: str
    connectors: dict[str, Connector] = field(default_factory=dict)
    line: int | None = None
    implementation: str = "any"   # SSP: the FMI kind to run, "any", "ModelExchange" or "CoSimulation"


@dataclass
class Transformation:
    kind: str                         # "linear" or "map"
    factor: float = 1.0
    offset: float = 0.0
    mapping: dict | None = None       # for map transformations (integer/enumeration)


@dataclass
class Connection:
    src_component: str
    src_connector: str
    dst_component: str
    dst_connector: str
    transformation: Transformation | None = None
    suppress_unit_conversion: bool = False
    line: int | None = None
    extrapolation: int | None = None     # order for the source output (connection_extrapolation.py); None: global

    @property
    def src(self) -> str:
        return f"{self.src_component}.{self.src_connector}"

    @property
    def dst(self) -> str:
        return f"{self.dst_component}.{self.dst_connector}"


@dataclass
class ParameterValue:
    component: str
    variable: str
    type: str
    value: object
    origin: str               # file (and element) the value came from, for messages and inspect
    unit: str | None = None   # the unit the value is given in (ssv), None: the variable's own
    via: tuple | None = None  # while the SSD is read: the (system, connector) it was given to (parser.connector_values)


@dataclass
class MasterSettings:
    """Master settings read from annotations; None means 'not given in the file'."""
    step_size: float | None = None
    algorithm: str | None = None      # as written: the name is checked where settings are resolved (settings.py)
    algorithm_line: int | None = None  # the line that names it, for that check's message
    record_interval: float | None = None
    step_multiples: dict[str, int] = field(default_factory=dict)
    record: list[str] = field(default_factory=list)   # record patterns
    source: str | None = None  # which annotation supplied the step size
    algorithm_options: dict = field(default_factory=dict)   # master.algorithm_options name -> value


@dataclass
class SystemModel:
    name: str
    ssd_path: Path
    root: Path                                   # folder that 'source' attributes are relative to
    version: str
    components: dict[str, Component] = field(default_factory=dict)
    connections: list[Connection] = field(default_factory=list)
    parameters: list[ParameterValue] = field(default_factory=list)
    units: dict[str, Unit] = field(default_factory=dict)
    start_time: float | None = None
    stop_time: float | None = None
    settings: MasterSettings = field(default_factory=MasterSettings)
    annotations: dict[str, object] = field(default_factory=dict)  # type -> lxml element, for plugins
    structure: str | None = None     # the structure key when read to be reused (parser.read_ssd), else None
    #: (parameter file, name) of the values that name no connector or variable: SSP ignores them (SSP 1.0 5.3.3);
    #: the plan says so in one warning per file
    ignored_parameters: list[tuple[str, str]] = field(default_factory=list)
