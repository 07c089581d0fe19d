"""The SSP model's records (``master.ssp.model``, ``archive``, ``parser``, ``power_bonds``) are plain classes and
named tuples, not dataclasses (a run defines them all, and Python 3.11 compiles a dataclass's methods from source
in every process). What they replaced is the reference here: the dataclasses they were, declared as they were, must
take the same arguments (order, keywords, defaults, a new container per instance) and give the same repr and
equality; the frozen ones stay immutable."""
from __future__ import annotations

import copy
import dataclasses
import inspect
import pickle
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from master.ssp import archive, model, parser, power_bonds
from master.records import replaced
from master.units import Unit


# ------------------------------------------------------------------- the dataclasses as they were declared
@dataclass
class Connector:
    name: str
    kind: str
    type: str | None = None
    unit: str | None = None
    line: int | None = None


@dataclass
class Component:
    name: str
    source: str
    fmu_path: Path
    type: str
    connectors: dict[str, Connector] = field(default_factory=dict)
    line: int | None = None
    implementation: str = "any"


@dataclass
class Transformation:
    kind: str
    factor: float = 1.0
    offset: float = 0.0
    mapping: dict | None = None


@dataclass
class Connection:
    src_component: str
    src_connector: str
    dst_component: str
    dst_connector: str
    transformation: Transformation | None = None
    suppress_unit_conversion: bool = False
    line: int | None = None
    extrapolation: int | None = None


@dataclass
class ParameterValue:
    component: str
    variable: str
    type: str
    value: object
    origin: str
    unit: str | None = None
    via: tuple | None = None


@dataclass
class MasterSettings:
    step_size: float | None = None
    algorithm: str | None = None
    algorithm_line: int | None = None
    record_interval: float | None = None
    step_multiples: dict[str, int] = field(default_factory=dict)
    record: list[str] = field(default_factory=list)
    source: str | None = None
    algorithm_options: dict = field(default_factory=dict)


@dataclass
class SystemModel:
    name: str
    ssd_path: Path
    root: Path
    version: str
    components: dict[str, Component] = field(default_factory=dict)
    connections: list[Connection] = field(default_factory=list)
    parameters: list[ParameterValue] = field(default_factory=list)
    units: dict[str, Unit] = field(default_factory=dict)
    start_time: float | None = None
    stop_time: float | None = None
    settings: MasterSettings = field(default_factory=MasterSettings)
    annotations: dict[str, object] = field(default_factory=dict)
    structure: str | None = None
    ignored_parameters: list[tuple[str, str]] = field(default_factory=list)


@dataclass
class ScenarioSource:
    path: Path
    ssd_path: Path
    root: Path
    tempdir: Path | None = None
    memory: object = None


@dataclass
class _Written:
    stat: tuple | None
    sha256: str | None
    files: dict
    fmus: dict
    validated: bool = True
    shape: int | None = None


@dataclass
class PowerBond:
    name: str
    effort: object
    flow: object


@dataclass(frozen=True)
class MemoryArchive:
    ssd: bytes
    members: dict
    validated: bool
    shape: int | None = None


@dataclass(frozen=True)
class _Structure:
    units: dict
    components: dict
    connections: tuple
    size: int
    system_connectors: frozenset = None
    reach: object = None


PLAIN = [(model.Connector, Connector), (model.Component, Component), (model.Transformation, Transformation),
         (model.Connection, Connection), (model.ParameterValue, ParameterValue),
         (model.MasterSettings, MasterSettings), (model.SystemModel, SystemModel),
         (archive.ScenarioSource, ScenarioSource), (archive._Written, _Written), (power_bonds.PowerBond, PowerBond)]
FROZEN = [(archive.MemoryArchive, MemoryArchive), (parser._Structure, _Structure)]


def _arguments(cls) -> list[tuple]:
    """(name, kind, the default's repr) of the constructor: a default factory reads ``<factory>`` in both."""
    return [(p.name, p.kind, repr(p.default)) for p in inspect.signature(cls).parameters.values()]


def _required(ref) -> list[str]:
    """The fields without a default, in order."""
    return [f.name for f in dataclasses.fields(ref)
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]


def _ids(c):
    return getattr(c, "__qualname__", "")


@pytest.mark.parametrize("ours, ref", PLAIN + FROZEN, ids=_ids)
def test_the_constructor_takes_what_the_dataclass_took(ours, ref):
    assert not dataclasses.is_dataclass(ours)
    assert _arguments(ours) == _arguments(ref)
    given = {name: f"{name}-value" for name in _required(ref)}
    assert repr(ours(*given.values())) == repr(ref(*given.values()))
    for f in dataclasses.fields(ref):        # each field by keyword, the others given or left to their defaults
        kw = {**given, f.name: (f.name, "given")}
        a = ours(**kw)
        assert getattr(a, f.name) == (f.name, "given") and repr(a) == repr(ref(**kw))
    every = [(f.name, k) for k, f in enumerate(dataclasses.fields(ref))]      # all of them by position
    assert repr(ours(*every)) == repr(ref(*every))
    with pytest.raises(TypeError):
        ours(*every, "one too many")
    with pytest.raises(TypeError):
        ours(*given.values(), no_such_field=1)


@pytest.mark.parametrize("ours, ref", PLAIN, ids=_ids)
def test_plain_records_compare_by_fields_and_are_unhashable(ours, ref):
    args = _required(ref)
    a, b = ours(*args), ours(*args)
    assert a == b and not a != b and a is not b
    assert a != ref(*args)                           # another class is never equal, as between dataclasses
    setattr(b, dataclasses.fields(ref)[-1].name, "changed")     # mutable, as they were
    assert a != b
    with pytest.raises(TypeError):
        hash(a)
    assert copy.copy(a) == a and pickle.loads(pickle.dumps(a)) == a


@pytest.mark.parametrize("ours, ref", PLAIN, ids=_ids)
def test_each_instance_gets_its_own_default_containers(ours, ref):
    args = _required(ref)
    a, b = ours(*args), ours(*args)
    made = [f.name for f in dataclasses.fields(ref) if f.default_factory is not dataclasses.MISSING]
    for name in made:
        assert repr(getattr(a, name)) == repr(getattr(ref(*args), name))      # {}, [] or MasterSettings()
        assert getattr(a, name) is not getattr(b, name)
    # an explicit None stays None, as the dataclass kept it
    for name in made:
        assert getattr(ours(*args, **{name: None}), name) is None


@pytest.mark.parametrize("ours, ref", FROZEN, ids=_ids)
def test_frozen_records_stay_immutable_and_hash_as_equality(ours, ref):
    args = [("t", 1), ("u", 2), 3.5, 4]
    a, b = ours(*args), ours(*args)
    assert a == b and hash(a) == hash(b) == hash(ref(*args))
    assert ours(*args[:-1], 5) != a
    for f in dataclasses.fields(ref):
        with pytest.raises(AttributeError):
            setattr(a, f.name, "x")
        with pytest.raises(AttributeError):
            setattr(ref(*args), f.name, "x")
    assert a == b and pickle.loads(pickle.dumps(a)) == a


def test_a_connection_names_its_ends():
    c = model.Connection("a.b", "y", "c", "u")
    assert (c.src, c.dst) == ("a.b.y", "c.u")


def test_a_component_copied_with_its_file_changed():
    comp = model.Component("c", "resources/c.fmu", Path("/a/c.fmu"), "application/x-fmu-sharedlibrary",
                           {"u": model.Connector("u", "input", "Real")}, 3, "CoSimulation")
    moved = replaced(comp, fmu_path=Path("/b/c.fmu"))
    ref = dataclasses.replace(Component(**vars(comp)), fmu_path=Path("/b/c.fmu"))
    assert repr(moved) == repr(ref) and moved.fmu_path == Path("/b/c.fmu")
    assert comp.fmu_path == Path("/a/c.fmu") and moved.connectors is comp.connectors
    assert type(moved) is model.Component and moved != comp
