"""Small helpers for the pythonfmu shells: variables with units and FMI 2.0 UnitDefinitions.

pythonfmu 0.7's ``Real`` has no ``unit`` attribute, so ``UnitReal`` adds it to the ``<Real>``
element, and ``UnitsMixin.to_xml`` inserts the matching ``<UnitDefinitions>`` (with SI base-unit
exponents) that FMI 2.0 requires for every unit used.
"""
from __future__ import annotations

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


class UnitsMixin:
    """Mixin for Fmi2Slave subclasses: typed registration helpers, UnitDefinitions, and faster
    get/set of values.

    pythonfmu's ``get_real`` & co. test ``isinstance`` (an ABC check) and call a lambda per value;
    the overrides below look the value references up in per-type tables built once (after all
    variables are registered) and read/write the attributes directly.  Same results and the same
    errors: an unknown reference or one of another type falls back to pythonfmu's method, which
    raises its TypeError.
    """

    def _vr_tables(self):
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
        return cache[1]

    def _get(self, cls, conv, vrs, fallback):
        # one reader per (type, reference list), cached: the master asks for the same lists every step
        tables = self._vr_tables()
        readers = self.__dict__["_vr_readers"]
        key = (cls, tuple(vrs))
        read = readers.get(key)
        if read is None:
            get = tables[cls][0]
            if any(vr not in get for vr in vrs):   # pythonfmu's method raises its TypeError
                return getattr(super(UnitsMixin, self), fallback)(vrs)
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
        return read()

    def _set(self, cls, vrs, values, fallback):
        put = self._vr_tables()[cls][1]
        for vr, value in zip(vrs, values):
            a = put.get(vr)
            if a is None:           # not settable / another type: pythonfmu sets again and raises
                return getattr(super(UnitsMixin, self), fallback)(vrs, values)
            if a.__class__ is str:
                setattr(self, a, value)
            else:
                a(value)

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

    def par_real(self, name, unit, description):
        self.register_variable(UnitReal(name, unit=unit, description=description, **_PAR))

    def par_int(self, name, description):
        self.register_variable(Integer(name, description=description, **_PAR))

    def par_bool(self, name, description):
        self.register_variable(Boolean(name, description=description, **_PAR))

    def par_str(self, name, description):
        self.register_variable(String(name, description=description, **_PAR))

    def in_real(self, name, unit, description):
        self.register_variable(UnitReal(name, unit=unit, description=description,
                                        causality=Fmi2Causality.input,
                                        variability=Fmi2Variability.continuous))

    def in_int(self, name, description):
        self.register_variable(Integer(name, description=description, causality=Fmi2Causality.input,
                                       variability=Fmi2Variability.discrete))

    def out_real(self, name, unit, description):
        self.register_variable(UnitReal(name, unit=unit, description=description,
                                        causality=Fmi2Causality.output,
                                        variability=Fmi2Variability.continuous))

    def out_int(self, name, description):
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
