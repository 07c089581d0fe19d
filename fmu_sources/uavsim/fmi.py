"""Small helpers for the pythonfmu shells: variables with units and FMI 2.0 UnitDefinitions.

pythonfmu 0.7's ``Real`` has no ``unit`` attribute, so ``UnitReal`` adds it to the ``<Real>``
element, and ``UnitsMixin.to_xml`` inserts the matching ``<UnitDefinitions>`` (with SI base-unit
exponents) that FMI 2.0 requires for every unit used.  ``StateMixin`` gives a shell FMI's get/set FMU
state (rollback: iterative coupling).

The instances of a shell class share one variable table (``_VarTable``, built from the first instance):
pythonfmu builds every ScalarVariable with a getter and a setter closure per instance, 1.5 MB for the
strategy's 1210 variables, which made 256 UAVs cost 390 MB in variable objects alone.  Each instance keeps
its values as its own attributes, as before.
"""
from __future__ import annotations

import copy
import ctypes
import types
from abc import ABCMeta
from operator import attrgetter
from xml.etree.ElementTree import Element, SubElement

from pythonfmu.enums import Fmi2Causality, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

# unit -> SI base-unit exponents (FMI 2.0 BaseUnit attributes) and factor
UNITS = {
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "m2": {"m": 2},
    "kg": {"kg": 1},
    "kg/m3": {"kg": 1, "m": -3},
    "s": {"s": 1},
    "1/s": {"s": -1},
    "1/s2": {"s": -2},
    "deg": {"rad": 1, "factor": 0.017453292519943295},
    "W": {"kg": 1, "m": 2, "s": -3},
    "J": {"kg": 1, "m": 2, "s": -2},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
    "A": {"A": 1},
    "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "Ah": {"A": 1, "s": 1, "factor": 3600.0},
    "1": {},
}


class UnitReal(Real):
    def __init__(self, name, unit=None, **kwargs):
        super().__init__(name, **kwargs)
        self.unit = unit

    def to_xml(self) -> Element:
        node = super().to_xml()
        if self.unit:
            node.find("Real").set("unit", self.unit)
        return node


_PAR = dict(causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed)


_DEFAULT_ACCESSOR = "register_variable.<locals>.<lambda>"


def _accessor(fn, self, var, kind):
    """A fast accessor for var: the attribute name when pythonfmu's default getter/setter is used
    (a plain attribute of the slave), else the registered callable; None if there is none."""
    if fn is None:
        return None
    if getattr(fn, "__qualname__", "").endswith(_DEFAULT_ACCESSOR) and var.name == var.local_name:
        return var.local_name
    return fn


class _VarTable:
    """The variables of a shell class, shared by its instances: the ScalarVariable objects (what
    modelDescription.xml lists, without per-instance getter/setter closures), their names in value-reference
    order, and per type the attribute read (get) and written (set) for each value reference."""

    __slots__ = ("vars", "names", "tables", "plain", "raw_readers")

    def __init__(self, variables):
        self.vars = variables
        self.names = tuple(v.name for v in variables.values())
        self.plain = {}          # names -> all plain instance attributes (UnitsMixin._plain)
        self.raw_readers = {}    # (type, value references) -> UnitsMixin._raw_reader's answer, any instance's
        self.tables = {}
        for cls in (Real, Integer, Boolean, String):
            vrs = [vr for vr, v in variables.items() if isinstance(v, cls)]
            self.tables[cls] = ({vr: variables[vr].name for vr in vrs},
                                {vr: variables[vr].name for vr in vrs if variables[vr].setter is not None})


def _shareable(variables) -> bool:
    """True when every variable uses pythonfmu's default accessors on a plain attribute of the slave (then
    the attribute name is all an instance needs); a custom getter/setter or a nested name binds the
    variable to one instance."""
    return all(var.name == var.local_name and isinstance(var, (Real, Integer, Boolean, String))
               and isinstance(_accessor(var.getter, None, var, "get"), str)
               and (var.setter is None or isinstance(_accessor(var.setter, None, var, "set"), str))
               for var in variables.values())


def _adopt_table(cls, obj) -> None:
    """After obj's __init__: the first instance of cls gives the class its table (its own variables, their
    closures dropped: they hold that instance); later instances, which registered nothing, take it."""
    d = obj.__dict__
    table = cls.__dict__.get("_var_table")
    if table is None:
        variables = d.get("vars")
        table = _VarTable(variables) if variables and _shareable(variables) else False
        if table:
            for var in variables.values():
                var.getter = var.setter = None
        cls._var_table = table
    if not table:
        return
    n = d.pop("_n_registered", None)
    if d["vars"] is not table.vars:
        if n != len(table.names):
            raise RuntimeError(f"{cls.__name__} instance {d.get('instance_name')!r} registered {n or 0} variables, "
                               f"its class's first instance {len(table.names)}: the instances of a class share one "
                               "variable table, so each must register the same variables")
        d["vars"] = table.vars
    d["_vr_readers"], d["_vr_writers"] = {}, {}


class _SharedVariables(ABCMeta):
    """Metaclass of UnitsMixin: the variable table is settled once an instance's __init__ (the shell's,
    which registers the variables) has returned."""

    def __call__(cls, *args, **kwargs):
        obj = super().__call__(*args, **kwargs)
        _adopt_table(cls, obj)
        return obj


def _table_of(obj):
    """obj's shared variable table, or None (a class whose variables are bound to their instance)."""
    table = type(obj).__dict__.get("_var_table")
    return table if table and obj.__dict__.get("vars") is table.vars else None


class _PythonfmuMethods:
    """pythonfmu's get_*/set_* and FMU state (the same loop, the same errors) for instances with a shared
    table, whose variables have no getter/setter closures to call; other instances use pythonfmu's own.
    UnitsMixin falls back to these for requests its fast path refuses."""

    def _table_get(self, cls, conv, vrs, name):
        table = _table_of(self)
        if table is None:
            return getattr(super(), name)(vrs)
        names = table.tables[cls][0]
        out = []
        for vr in vrs:
            var = self.vars[vr]
            if not isinstance(var, cls):
                raise TypeError(f"Variable with valueReference={vr} is not of type {cls.__name__}!")
            out.append(conv(getattr(self, names[vr])))
        return out

    def _table_set(self, cls, vrs, values, name):
        table = _table_of(self)
        if table is None:
            return getattr(super(), name)(vrs, values)
        names = table.tables[cls][1]
        for vr, value in zip(vrs, values):
            var = self.vars[vr]
            if not isinstance(var, cls):
                raise TypeError(f"Variable with valueReference={vr} is not of type {cls.__name__}!")
            if vr not in names:
                raise TypeError(f"Variable with valueReference={vr} ({var.name}) cannot be set")
            setattr(self, names[vr], value)

    def get_real(self, vrs):
        return self._table_get(Real, float, vrs, "get_real")

    def get_integer(self, vrs):
        return self._table_get(Integer, int, vrs, "get_integer")

    def get_boolean(self, vrs):
        return self._table_get(Boolean, bool, vrs, "get_boolean")

    def get_string(self, vrs):
        return self._table_get(String, str, vrs, "get_string")

    def set_real(self, vrs, values):
        return self._table_set(Real, vrs, values, "set_real")

    def set_integer(self, vrs, values):
        return self._table_set(Integer, vrs, values, "set_integer")

    def set_boolean(self, vrs, values):
        return self._table_set(Boolean, vrs, values, "set_boolean")

    def set_string(self, vrs, values):
        return self._table_set(String, vrs, values, "set_string")

    def _get_fmu_state(self):
        if _table_of(self) is None:
            return super()._get_fmu_state()
        return {var.name: getattr(self, var.name) for var in self.vars.values()}

    def _set_fmu_state(self, state):
        table = _table_of(self)
        if table is None:
            return super()._set_fmu_state(state)
        settable = {n for _, put in table.tables.values() for n in put.values()}
        for name, value in state.items():
            if name in settable or name not in table.names:
                setattr(self, name, value)


class UnitsMixin(_PythonfmuMethods, metaclass=_SharedVariables):
    """Mixin for Fmi2Slave subclasses: typed registration helpers, UnitDefinitions, and faster
    get/set of values.

    pythonfmu's ``get_real`` & co. test ``isinstance`` (an ABC check) and call a lambda per value;
    the overrides below look the value references up in per-type tables built once (after all
    variables are registered) and read/write the attributes directly.  Same results and the same
    errors: an unknown reference or one of another type falls back to pythonfmu's method, which
    raises its TypeError.

    ``output_dependencies`` (a shell's class attribute) declares its direct feedthrough: output name -> the
    inputs it depends on within a step; an output not named depends on none.  pythonfmu writes no
    ``dependencies``, which FMI 2.0 reads as "depends on every input": masters that order or solve by them
    (OMSimulator) then see algebraic loops that are not there.  None (the default) writes nothing.
    """

    output_dependencies: dict | None = None

    def _vr_tables(self):
        table = _table_of(self)
        if table is not None:
            return table.tables
        cache = self.__dict__.get("_vr_cache")
        if cache is None or cache[0] != len(self.vars):      # built once, after registration
            tables = {}
            for cls in (Real, Integer, Boolean, String):
                get, put = {}, {}
                for vr, var in self.vars.items():
                    if isinstance(var, cls):
                        get[vr] = _accessor(var.getter, self, var, "get")
                        acc = _accessor(var.setter, self, var, "set")
                        if acc is not None:
                            put[vr] = acc
                tables[cls] = (get, put)
            cache = (len(self.vars), tables)
            self.__dict__["_vr_cache"] = cache
            self.__dict__["_vr_readers"] = {}
            self.__dict__["_vr_writers"] = {}
        return cache[1]

    def _reader(self, cls, conv, vrs):
        """A function returning the values of ``vrs`` (cached per type and reference list: the master
        asks for the same lists every step), or None if one of them is not a readable ``cls``."""
        tables = self._vr_tables()
        readers = self.__dict__["_vr_readers"]
        key = (cls, tuple(vrs))
        read = readers.get(key)
        if read is None:
            get = tables[cls][0]
            if any(vr not in get for vr in vrs):
                return None
            acc = [get[vr] for vr in vrs]
            if all(a.__class__ is str for a in acc):
                names = tuple(acc)
                if not names:
                    def read():
                        return []
                elif len(names) == 1:
                    name = names[0]

                    def read(_self=self, _n=name, _c=conv):
                        return [_c(getattr(_self, _n))]
                else:
                    ag = attrgetter(*names)

                    def read(_self=self, _ag=ag, _c=conv):
                        return [_c(v) for v in _ag(_self)]
            else:
                def read(_self=self, _acc=tuple(acc), _c=conv):
                    return [_c(getattr(_self, a) if a.__class__ is str else a()) for a in _acc]
            readers[key] = read
        return read

    def _writer(self, cls, vrs):
        """A function setting ``vrs`` to a list of values (cached like the readers), or None if one of
        them is not a settable ``cls``."""
        tables = self._vr_tables()
        writers = self.__dict__["_vr_writers"]
        key = (cls, tuple(vrs))
        write = writers.get(key)
        if write is None:
            put = tables[cls][1]
            if any(vr not in put for vr in vrs):
                return None
            acc = tuple(put[vr] for vr in vrs)
            plain = type(self).__setattr__ is object.__setattr__
            if plain and all(a.__class__ is str and not hasattr(type(self), a) for a in acc):
                # plain instance attributes (no property, no __setattr__): one dict update is setattr
                def write(values, _update=self.__dict__.update, _names=acc):
                    _update(zip(_names, values))
            else:
                def write(values, _self=self, _acc=acc):
                    for a, v in zip(_acc, values):
                        if a.__class__ is str:
                            setattr(_self, a, v)
                        else:
                            a(v)
            writers[key] = write
        return write

    def _get(self, cls, conv, vrs, fallback):
        read = self._reader(cls, conv, vrs)
        if read is None:                 # pythonfmu's method raises its TypeError
            return getattr(super(UnitsMixin, self), fallback)(vrs)
        return read()

    def _set(self, cls, vrs, values, fallback):
        write = self._writer(cls, vrs)
        if write is None:                # not settable / another type: pythonfmu sets again and raises
            return getattr(super(UnitsMixin, self), fallback)(vrs, values)
        write(values)

    def cosim_bind(self, op: str, typ: str, vrs):
        """In-process masters' fast path (cosim-master's master/fmi/inprocess.py): for op "get" a function
        returning the values of ``vrs`` as ``get_<typ>(vrs)`` would, for "set" a function of the values
        doing what ``set_<typ>(vrs, values)`` does; None when the call would fail (the master then uses
        the FMI functions, which raise the error)."""
        cls = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}.get(typ)
        if cls is None:
            return None
        vrs = [int(v) for v in vrs]
        if op == "get_raw":
            return self._raw_reader(cls, vrs)
        if op == "set_raw":
            return self._raw_writer(cls, vrs)
        if op == "get":
            return self._reader(cls, {Real: float, Integer: int, Boolean: bool, String: str}[cls], vrs)
        if op == "set":
            return self._writer(cls, vrs)
        return None

    def _raw_reader(self, cls, vrs):
        """For ``cosim_bind("get_raw", ...)``: (fetch, single) with ``fetch(slave)`` giving the values of
        ``vrs`` unconverted (a tuple, or the value itself when ``single``), for a master that stores them in a
        buffer of the FMI type (which converts as get_<type> would); None unless every one is an attribute.
        ``fetch`` is an operator.attrgetter: no Python frame per call, and valid for any instance, so instances
        sharing a table share it (a master binds the same references of every UAV's FMU)."""
        table = _table_of(self)
        known = table.raw_readers if table is not None else None
        key = (cls, tuple(vrs))
        if known is not None and key in known:
            return known[key]
        get = self._vr_tables()[cls][0]
        names = [get.get(vr) for vr in vrs]
        reader = None
        if names and all(a.__class__ is str for a in names):
            reader = attrgetter(*names), len(names) == 1
        if known is not None:
            if len(known) >= 256:
                known.clear()
            known[key] = reader
        return reader

    def _raw_writer(self, cls, vrs):
        """For ``cosim_bind("set_raw", ...)``: (update, names) such that ``update(zip(names, values))`` does
        what set_<type>(vrs, values) does, for a master that calls it inline (no Python frame); None unless every
        one is a plain instance attribute (no property, no __setattr__)."""
        put = self._vr_tables()[cls][1]
        names = tuple(put.get(vr) for vr in vrs)
        if not names or type(self).__setattr__ is not object.__setattr__ or not self._plain(names):
            return None
        return self.__dict__.update, names

    def _plain(self, names: tuple) -> bool:
        """Every one of ``names`` is a str the class does not define (no property or other descriptor): a plain
        instance attribute. The answer depends on the class alone, so instances sharing a table ask it once per
        tuple (a strategy's start values name a thousand parameters)."""
        table = _table_of(self)
        known = table.plain if table is not None else None
        if known is not None and names in known:
            return known[names]
        cls = type(self)
        plain = all(a.__class__ is str and not hasattr(cls, a) for a in names)
        if known is not None:
            if len(known) >= 256:
                known.clear()
            known[names] = plain
        return plain

    def get_real(self, vrs):
        return self._get(Real, float, vrs, "get_real")

    def get_integer(self, vrs):
        return self._get(Integer, int, vrs, "get_integer")

    def get_boolean(self, vrs):
        return self._get(Boolean, bool, vrs, "get_boolean")

    def get_string(self, vrs):
        return self._get(String, str, vrs, "get_string")

    def set_real(self, vrs, values):
        return self._set(Real, vrs, values, "set_real")

    def set_integer(self, vrs, values):
        return self._set(Integer, vrs, values, "set_integer")

    def set_boolean(self, vrs, values):
        return self._set(Boolean, vrs, values, "set_boolean")

    def set_string(self, vrs, values):
        return self._set(String, vrs, values, "set_string")

    def _in_table(self, name) -> bool:
        """True when the class's shared table holds the variable registered next (then nothing is built):
        the instances of a class must register the same variables in the same order."""
        table = type(self).__dict__.get("_var_table")
        if not table:
            return False
        d = self.__dict__
        n = d.get("_n_registered", 0)
        if n >= len(table.names) or table.names[n] != name:
            first = table.names[n] if n < len(table.names) else "nothing"
            raise RuntimeError(f"{type(self).__name__} registers variable {n} as {name!r}, its first instance "
                               f"registered {first!r}: the instances of a class share one variable table")
        d["_n_registered"] = n + 1
        return True

    def _run_in_table(self, names: tuple) -> bool:
        """True when the class's shared table holds ``names`` as the variables registered next, which are then
        taken as registered (a shell with a thousand parameters sets their defaults itself, in one update)."""
        table = type(self).__dict__.get("_var_table")
        if not table:
            return False
        d = self.__dict__
        n = d.get("_n_registered", 0)
        if table.names[n:n + len(names)] != names:
            return False        # registered one by one, which names the first difference
        d["_n_registered"] = n + len(names)
        return True

    def register_variable(self, var, nested: bool = True):
        if not self._in_table(var.name):
            super().register_variable(var, nested)

    def par_real(self, name, unit, description):
        if not self._in_table(name):
            self.register_variable(UnitReal(name, unit=unit, description=description, **_PAR))

    def par_int(self, name, description):
        if not self._in_table(name):
            self.register_variable(Integer(name, description=description, **_PAR))

    def par_bool(self, name, description):
        if not self._in_table(name):
            self.register_variable(Boolean(name, description=description, **_PAR))

    def par_str(self, name, description):
        if not self._in_table(name):
            self.register_variable(String(name, description=description, **_PAR))

    def in_real(self, name, unit, description):
        if not self._in_table(name):
            self.register_variable(UnitReal(name, unit=unit, description=description,
                                            causality=Fmi2Causality.input,
                                            variability=Fmi2Variability.continuous))

    def in_int(self, name, description):
        if not self._in_table(name):
            self.register_variable(Integer(name, description=description, causality=Fmi2Causality.input,
                                           variability=Fmi2Variability.discrete))

    def out_real(self, name, unit, description):
        if not self._in_table(name):
            self.register_variable(UnitReal(name, unit=unit, description=description,
                                            causality=Fmi2Causality.output,
                                            variability=Fmi2Variability.continuous))

    def out_int(self, name, description):
        if not self._in_table(name):
            self.register_variable(Integer(name, description=description, causality=Fmi2Causality.output,
                                           variability=Fmi2Variability.discrete))

    def to_xml(self, model_options=dict()) -> Element:
        root = super().to_xml(model_options)
        # pythonfmu lists only <Outputs>; FMI 2.0 also requires <InitialUnknowns> with every output
        # whose initial is "calculated" (the default for outputs)
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs") if structure is not None else None
        if outputs is not None and structure.find("InitialUnknowns") is None:
            init = SubElement(structure, "InitialUnknowns")
            for u in outputs:
                SubElement(init, "Unknown", index=u.get("index"))
        if outputs is not None and self.output_dependencies is not None:
            _declare_dependencies(root, self.output_dependencies, type(self).__name__)
        used = sorted({v.unit for v in self.vars.values() if isinstance(v, UnitReal) and v.unit})
        if used:
            ud = Element("UnitDefinitions")
            for u in used:
                unit = SubElement(ud, "Unit", name=u)
                spec = dict(UNITS.get(u, {}))
                SubElement(unit, "BaseUnit", {k: (repr(float(v)) if k == "factor" else str(v))
                                              for k, v in spec.items()})
            # FMI 2.0 order: CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, ...
            idx = list(root).index(root.find("CoSimulation")) + 1
            root.insert(idx, ud)
        return root


def _declare_dependencies(root: Element, feedthrough: dict, model: str) -> None:
    """``dependencies`` on every output Unknown (Outputs and InitialUnknowns): the indices of the inputs in
    ``feedthrough[name]``, empty for an output not named there.  The shells publish their outputs only in
    exitInitializationMode and doStep, so in Initialization Mode too an output changes with no input."""
    variables = root.find("ModelVariables").findall("ScalarVariable")
    index = {v.get("name"): i + 1 for i, v in enumerate(variables)}
    causality = {v.get("name"): v.get("causality") for v in variables}
    for name, inputs in feedthrough.items():
        if causality.get(name) != "output":
            raise ValueError(f"{model}.output_dependencies: {name!r} is no output")
        for u in inputs:
            if causality.get(u) != "input":
                raise ValueError(f"{model}.output_dependencies[{name!r}]: {u!r} is no input")
    names = {i: n for n, i in index.items()}
    structure = root.find("ModelStructure")
    for section in ("Outputs", "InitialUnknowns"):
        for unknown in structure.find(section):
            deps = feedthrough.get(names[int(unknown.get("index"))], ())
            unknown.set("dependencies", " ".join(str(i) for i in sorted(index[u] for u in deps)))


#: slave attributes that are no state: pythonfmu's variable table and log queue, the accessor caches (closures
#: over this very instance, valid as long as its __dict__ object is), the instance's identity
_NOT_STATE = frozenset({"vars", "log_queue", "_vr_cache", "_vr_readers", "_vr_writers", "instance_name",
                        "resources", "visible", "guid"})
#: kept by reference in a state, never copied: code and loaded libraries (a model's bound kernel closures, the
#: kernels object holding a ctypes library), which do not change while the FMU runs
_CODE = (types.FunctionType, types.BuiltinFunctionType, types.MethodType, types.ModuleType, ctypes.CDLL,
         ctypes._CFuncPtr)
_IMMUTABLE = frozenset({float, int, bool, str, bytes, complex, type(None)})


_PLAIN: dict = {}        # class -> its slots, or None: not a plain record (decided once per class)


def _record_slots(t):
    """The slots of a class defined in Python that copies like a plain record (its attributes, ``__dict__``
    and slots, are its state: no custom copy or pickle protocol, no built-in base but object), else None."""
    if t not in _PLAIN:
        _PLAIN[t] = _slots(t) if _plain(t) else None
    return _PLAIN[t]


def _plain(t) -> bool:
    return (t.__flags__ & (1 << 9)                # Py_TPFLAGS_HEAPTYPE: defined in Python
            and all(b is object or b.__flags__ & (1 << 9) for b in t.__mro__)
            and "__deepcopy__" not in dir(t) and t.__reduce_ex__ is object.__reduce_ex__
            and t.__reduce__ is object.__reduce__ and getattr(t, "__setstate__", None) is None)


def _slots(t) -> tuple:
    return tuple(n for c in t.__mro__ for n in c.__dict__.get("__slots__", ()) if n not in ("__dict__", "__weakref__"))


_MISSING = object()
try:
    from numpy import ndarray as _ndarray
except ImportError:              # a bundle without numpy: no array to copy
    _ndarray = None


def _copy(obj, memo: dict):
    """A deep copy of a state value: like copy.deepcopy (which it falls back to for random generators,
    geometry ...), but shares code and libraries and copies plain records, containers and numeric arrays
    directly, several times faster (a model keeps hundreds of small slotted records, e.g. the wind's drawn
    intervals; bench/bench_fmu_state.py)."""
    t = type(obj)
    if t in _IMMUTABLE:
        return obj
    found = memo.get(id(obj))
    if found is not None:
        return found
    imm = _IMMUTABLE
    if t is list:
        out = memo[id(obj)] = []
        out.extend([x if type(x) in imm else _copy(x, memo) for x in obj])
    elif t is dict:
        out = memo[id(obj)] = {}
        out.update({k: v if type(v) in imm else _copy(v, memo) for k, v in obj.items()})
    elif t is tuple:
        out = tuple([x if type(x) in imm else _copy(x, memo) for x in obj])
    elif t is _ndarray and obj.dtype.hasobject is False and obj.base is None:
        out = obj.copy()         # an array that owns its numbers (a view would need its base shared)
    elif isinstance(obj, _CODE) or t.__name__ == "Kernels":
        out = obj
    elif (slots := _record_slots(t)) is not None:
        out = memo[id(obj)] = object.__new__(t)
        setattr_ = object.__setattr__
        for name in slots:
            v = getattr(obj, name, _MISSING)
            if v is not _MISSING:
                setattr_(out, name, v if type(v) in imm else _copy(v, memo))
        if hasattr(obj, "__dict__"):
            out.__dict__.update({k: v if type(v) in imm else _copy(v, memo) for k, v in obj.__dict__.items()})
    else:
        out = copy.deepcopy(obj, memo)
    memo[id(obj)] = out
    return out


class StateMixin:
    """FMI get/set FMU state for a pythonfmu slave (pythonfmu calls ``_get_fmu_state`` / ``_set_fmu_state``
    for fmi2GetFMUstate / fmi2SetFMUstate; cosim-master's in-process path calls them too).

    The state is a deep copy of every instance attribute: parameters, inputs, outputs, the model objects with
    their sub-step state, random generators (numpy's copy their bit generator's state) and caches, so a
    restore is bit-exact whatever the model keeps. pythonfmu's default saves the registered variables only,
    which misses all of that. Code and libraries are shared, not copied. Restoring copies the saved values
    again (a state restores any number of times), updates the instance's own __dict__ in place (the fast
    accessors hold it) and drops attributes made after the save."""

    def _get_fmu_state(self):
        memo: dict = {}
        state = {k: _copy(v, memo) for k, v in self.__dict__.items() if k not in _NOT_STATE}
        return state

    def _set_fmu_state(self, state):
        d = self.__dict__
        for k in [k for k in d if k not in _NOT_STATE and k not in state]:
            del d[k]
        memo: dict = {}
        d.update({k: _copy(v, memo) for k, v in state.items()})
