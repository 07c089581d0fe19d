"""The flattened system a scenario describes, independent of the XML it came from.

The records are plain classes with a hand-written ``__init__`` (the same arguments, defaults, ``repr`` and equality
as the dataclasses they were; a default container is a new one for each instance): every run defines them, and
Python 3.11 compiles a dataclass's generated methods from source in every process (``master.records``)."""
from __future__ import annotations

from pathlib import Path

from ..records import Record
from ..units import Unit

# SSP connector type names mapped to the four FMI 2.0 base types the master moves around.
SSP_TYPES = ("Real", "Integer", "Boolean", "String", "Enumeration", "Binary")
# the component type of an input table (OMSimulator's convention): a CSV file whose columns drive inputs
CSV_SOURCE_TYPE = "text/csv"


class _Factory:
    """The default of an argument whose value is a new container for each instance (shown as a dataclass shows
    a default factory): a caller's explicit None stays None, as it did."""
    __slots__ = ()

    def __repr__(self):
        return "<factory>"


_NEW = _Factory()


class Connector(Record):
    def __init__(self, name: str, kind: str, type: str | None = None, unit: str | None = None,
                 line: int | None = None):
        self.name = name
        self.kind = kind            # input, output, parameter, calculatedParameter, inout
        self.type = type            # one of SSP_TYPES, None when the SSD leaves it to the FMU
        self.unit = unit
        self.line = line


class Component(Record):
    def __init__(self, name: str, source: str, fmu_path: Path, type: str,
                 connectors: dict[str, Connector] = _NEW, line: int | None = None,
                 implementation: str = "any"):
        self.name = name            # flattened, dotted path for components of nested systems
        self.source = source        # as written in the SSD
        self.fmu_path = fmu_path    # resolved on disk
        self.type = type
        self.connectors = {} if connectors is _NEW else connectors
        self.line = line
        self.implementation = implementation    # SSP: the FMI kind to run, "any", "ModelExchange" or "CoSimulation"


class Transformation(Record):
    def __init__(self, kind: str, factor: float = 1.0, offset: float = 0.0, mapping: dict | None = None):
        self.kind = kind            # "linear" or "map"
        self.factor = factor
        self.offset = offset
        self.mapping = mapping      # for map transformations (integer/enumeration)


class Connection(Record):
    def __init__(self, src_component: str, src_connector: str, dst_component: str, dst_connector: str,
                 transformation: Transformation | None = None, suppress_unit_conversion: bool = False,
                 line: int | None = None, extrapolation: int | None = None):
        self.src_component = src_component
        self.src_connector = src_connector
        self.dst_component = dst_component
        self.dst_connector = dst_connector
        self.transformation = transformation
        self.suppress_unit_conversion = suppress_unit_conversion
        self.line = line
        self.extrapolation = extrapolation  # order for the source output (connection_extrapolation.py); None: global

    @property
    def src(self) -> str:
        return f"{self.src_component}.{self.src_connector}"

    @property
    def dst(self) -> str:
        return f"{self.dst_component}.{self.dst_connector}"


class ParameterValue(Record):
    def __init__(self, component: str, variable: str, type: str, value: object, origin: str,
                 unit: str | None = None, via: tuple | None = None):
        self.component = component
        self.variable = variable
        self.type = type
        self.value = value
        self.origin = origin        # file (and element) the value came from, for messages and inspect
        self.unit = unit            # the unit the value is given in (ssv), None: the variable's own
        self.via = via      # while the SSD is read: the (system, connector) it was given to (parser.connector_values)


class MasterSettings(Record):
    """Master settings read from annotations; None means 'not given in the file'."""
    def __init__(self, step_size: float | None = None, algorithm: str | None = None, algorithm_line: int | None = None,
                 record_interval: float | None = None, step_multiples: dict[str, int] = _NEW,
                 record: list[str] = _NEW, source: str | None = None, algorithm_options: dict = _NEW):
        self.step_size = step_size
        self.algorithm = algorithm      # as written: the name is checked where settings are resolved (settings.py)
        self.algorithm_line = algorithm_line    # the line that names it, for that check's message
        self.record_interval = record_interval
        self.step_multiples = {} if step_multiples is _NEW else step_multiples
        self.record = [] if record is _NEW else record      # record patterns
        self.source = source                    # which annotation supplied the step size
        # master.algorithm_options name -> value
        self.algorithm_options = {} if algorithm_options is _NEW else algorithm_options


class SystemModel(Record):
    def __init__(self, name: str, ssd_path: Path, root: Path, version: str,
                 components: dict[str, Component] = _NEW, connections: list[Connection] = _NEW,
                 parameters: list[ParameterValue] = _NEW, units: dict[str, Unit] = _NEW,
                 start_time: float | None = None, stop_time: float | None = None,
                 settings: MasterSettings = _NEW, annotations: dict[str, object] = _NEW,
                 structure: str | None = None, ignored_parameters: list[tuple[str, str]] = _NEW):
        self.name = name
        self.ssd_path = ssd_path
        self.root = root                        # folder that 'source' attributes are relative to
        self.version = version
        self.components = {} if components is _NEW else components
        self.connections = [] if connections is _NEW else connections
        self.parameters = [] if parameters is _NEW else parameters
        self.units = {} if units is _NEW else units
        self.start_time = start_time
        self.stop_time = stop_time
        self.settings = MasterSettings() if settings is _NEW else settings
        self.annotations = {} if annotations is _NEW else annotations   # type -> lxml element, for plugins
        self.structure = structure      # the structure key when read to be reused (parser.read_ssd), else None
        #: (parameter file, name) of the values that name no connector or variable: SSP ignores them (SSP 1.0
        #: 5.3.3); the plan says so in one warning per file
        self.ignored_parameters = [] if ignored_parameters is _NEW else ignored_parameters
