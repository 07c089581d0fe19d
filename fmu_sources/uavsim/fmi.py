"""Small helpers for the pythonfmu shells: variables with units and FMI 2.0 UnitDefinitions.

pythonfmu 0.7's ``Real`` has no ``unit`` attribute, so ``UnitReal`` adds it to the ``<Real>``
element, and ``UnitsMixin.to_xml`` inserts the matching ``<UnitDefinitions>`` (with SI base-unit
exponents) that FMI 2.0 requires for every unit used.
"""
from __future__ import annotations

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


class UnitsMixin:
    """Mixin for Fmi2Slave subclasses: typed registration helpers and UnitDefinitions."""

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
