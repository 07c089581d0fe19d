"""Values a plan gives its variables before the run: the SSD's parameter values (checked against their variables'
types and converted to their units) and then the command line's or the API's, which win."""
from __future__ import annotations

from ..errors import ScenarioError
from ..log import warning
from ..ssp.model import SystemModel
from ..units import conversion
from .model import Plan, Var, element_names
from .variable_values import parse_value, value_error
from .variables import structural_sizes


def add_parameters(plan: Plan, model: SystemModel, units: dict, allow_nonfinite: bool, lenient: bool = False) -> None:
    """The SSD's parameter values, checked against their variables (and converted to their units). ``lenient``
    (``run --lenient``): a value in a unit defined nowhere is taken as given in its variable's unit, with a
    warning (OMSimulator's test suite writes ``[m]`` for m), instead of refused."""
    variables = plan.variables
    ignored: dict[str, list[str]] = {}
    for shown, name in getattr(model, "ignored_parameters", ()):
        ignored.setdefault(shown, []).append(name)
    for pv in model.parameters:
        v = variables.get(pv.component, {}).get(pv.variable)
        where = f"Parameter {pv.component}.{pv.variable}"
        if v is None:
            if pv.component in variables:       # a component's name, a name its FMU does not have: SSP ignores it
                ignored.setdefault(pv.origin.rsplit(":", 1)[0], []).append(f"{pv.component}.{pv.variable}")
                continue
            raise ScenarioError(f"no variable {pv.variable!r} in component {pv.component!r}",
                                file=pv.origin.rsplit(":", 1)[0], element=where, line=origin_line(pv.origin))
        if v.is_array:
            raise ScenarioError(f"{v.qualified} is an array: give its elements ({element_names(v.name, v.shape)[0]}, "
                                "...) one by one", file=pv.origin.rsplit(":", 1)[0], element=where,
                                line=origin_line(pv.origin))
        value = _check_value(v, pv.value, pv.type, pv.origin, where)
        why = value_error(v, value, allow_nonfinite)
        if why:
            raise ScenarioError(why, file=pv.origin.rsplit(":", 1)[0], element=where, line=origin_line(pv.origin))
        src_unit = getattr(pv, "unit", None)
        if v.type == "Real" and src_unit and v.unit and src_unit != v.unit:
            value = _converted(value, src_unit, v.unit, units, lenient, pv.origin, where)
        plan.params.append((v, value, pv.origin))
    for shown, names in ignored.items():
        _warn_ignored(shown, names)


def _converted(value: float, src_unit: str, unit: str, units: dict, lenient: bool, origin: str, where: str) -> float:
    """``value`` given in ``src_unit``, in ``unit``."""
    for u in (src_unit, unit):
        if units.get(u) is None:
            if lenient:
                warning(
                    "%s: %s: unit %s has no definition in the SSD or the FMU; the value is taken as given in %s "
                    "(lenient)", origin, where, u, unit)
                return value
            raise ScenarioError(f"unit {u} has no definition in the SSD or the FMU, so {src_unit} cannot "
                                f"be converted to {unit}", file=origin.rsplit(":", 1)[0], element=where,
                                line=origin_line(origin))
    conv = conversion(units.get(src_unit), units.get(unit))
    if conv is None:
        raise ScenarioError(f"unit {src_unit} cannot be converted to {unit}",
                            file=origin.rsplit(":", 1)[0], element=where, line=origin_line(origin))
    return conv[0] * value + conv[1]


#: names shown in the one warning per parameter file (a file of another tool may name hundreds of its own)
SHOWN_IGNORED = 5


def _warn_ignored(shown: str, names: list[str]) -> None:
    """One line per parameter file: its values that name no connector or variable of the system, which the
    standard says are ignored (SSP 1.0 5.3.3: "... or are ignored if no matching variable is found")."""
    more = f" and {len(names) - SHOWN_IGNORED} more" if len(names) > SHOWN_IGNORED else ""
    warning(
        "%s: ignoring %d parameter value%s that name%s no connector or variable of the system (SSP: ignored): %s%s",
        shown, len(names), "s" if len(names) > 1 else "", "" if len(names) > 1 else "s",
        ", ".join(names[:SHOWN_IGNORED]), more)


def add_overrides(plan: Plan, params: dict[str, object] | None, allow_nonfinite: bool = False) -> None:
    """Values given on the command line (or the API), after those of the SSD so that they win; checks every
    value the plan sets."""
    for qualified, raw in (params or {}).items():
        comp, _, name = plan.split(qualified)
        v = plan.variables[comp][name]
        plan.params.append((v, parse_value(v, raw, qualified, allow_nonfinite), "command line"))
    plan.params[:] = _whole_arrays(plan.params, plan)
    for v, _, origin in plan.params:
        sized = (v.causality == "structuralParameter"
                 and structural_sizes(plan.variables[v.component], plan.fmus[v.component]).get(v.name))
        if sized:
            raise ScenarioError(f"{v.qualified} is a structural parameter giving the size of {', '.join(sized)}; "
                                "changing it is not supported (arrays keep the sizes of the modelDescription)",
                                file=origin)
        if v.causality in ("output", "calculatedParameter", "local", "independent") and v.variability != "tunable":
            if v.causality != "local" or v.variability == "constant":
                raise ScenarioError(f"{v.qualified} has causality {v.causality} and cannot be given a value",
                                    file=origin)
        if v.variability == "constant":
            raise ScenarioError(f"{v.qualified} is a constant and cannot be given a value", file=origin)


def _whole_arrays(params: list, plan: Plan) -> list:
    """Values given to array elements, folded into one value of the whole array (FMI 3 sets an array as a
    whole): the modelDescription's start values with the elements given replaced, in the order given."""
    folded: dict[str, list] = {}
    out = []
    for v, value, origin in params:
        if v.index is None and not v.is_array:
            out.append((v, value, origin))
            continue
        whole = plan.variables[v.component][v.array or v.name]
        if whole.qualified not in folded:
            folded[whole.qualified] = list(whole.start)
            out.append((whole, folded[whole.qualified], origin))
        if v.is_array:
            folded[whole.qualified][:] = value
        else:
            folded[whole.qualified][v.index] = value
    return out


_INTEGER_SSP = ("Integer", "Enumeration")
#: the SSP value types a variable of each base type takes
_COMPATIBLE = {"Real": ("Real",), "Integer": _INTEGER_SSP, "Int64": _INTEGER_SSP, "UInt64": _INTEGER_SSP,
               "Boolean": ("Boolean",), "String": ("String",), "Binary": ("Binary",)}


def _check_value(v: Var, value, ssp_type, origin, where):
    if v.type == "Integer" and v.fmi_type == "Enumeration" and ssp_type == "Enumeration":
        return value
    if ssp_type not in _COMPATIBLE.get(v.type, ()):
        raise ScenarioError(f"a {ssp_type} value cannot be given to {v.qualified} of type {v.fmi_type}",
                            file=origin.rsplit(":", 1)[0], element=where, line=origin_line(origin))
    return value


def origin_line(origin: str):
    tail = origin.rsplit(":", 1)[-1]
    return int(tail) if tail.isdigit() else None
