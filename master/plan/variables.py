"""An FMU's modelDescription as the plan's variables: one ``Var`` per variable (an FMI 3.0 array also as its
elements), described once per model description and shared by every component of that FMU, and the outputs'
dependencies on inputs."""
from __future__ import annotations

from ..fmi.cache import LoadedFmu
from ..fmi.slave import OBJECT_FILL, array_shape, base_type
from .model import ComponentVariables, Var, element_names
from .variable_values import parse_value


def _var(comp: str, fmu: LoadedFmu, v) -> Var:
    unit = getattr(v, "unit", None)
    if unit is None and getattr(v, "declaredType", None) is not None:
        unit = getattr(v.declaredType, "unit", None)
    bt = base_type(fmu.fmi_version, v.type)
    return Var(comp, v.name, int(v.valueReference), bt or v.type, v.type, v.causality, v.variability, unit)


# model description -> (the description, kept alive for its id; its variables, component ""): a campaign worker
# plans the same FMUs run after run, and an FMU with a thousand variables costs milliseconds to describe
_VARIABLES: dict[int, tuple[object, dict[str, Var]]] = {}


def component_variables(comp: str, fmu: LoadedFmu) -> ComponentVariables:
    """Every variable by name; an FMI 3.0 array also as its elements."""
    cached = _VARIABLES.get(id(fmu.md))
    if cached is None or cached[0] is not fmu.md:
        cached = _VARIABLES[id(fmu.md)] = (fmu.md, _describe_variables("", fmu))
    return ComponentVariables(comp, cached[1])


def _describe_variables(comp: str, fmu: LoadedFmu) -> dict[str, Var]:
    by_vr = {v.valueReference: v for v in fmu.md.modelVariables}
    out = {}
    for mv in fmu.md.modelVariables:
        v = out[mv.name] = _var(comp, fmu, mv)
        shape = array_shape(mv, by_vr)
        if not shape:
            continue
        names = element_names(v.name, shape)
        start = _array_start(v, mv.start, len(names))
        out[v.name] = v.changed(shape=shape, start=start)
        for k, name in enumerate(names):
            out[name] = v.changed(name=name, shape=shape, index=k, array=v.name, start=start[k])
    return out


def _array_start(v: Var, text, size: int) -> tuple:
    """The start values of an array (a space-separated list in FMI 3), zeros (or false, "") when it has none."""
    if text is None:
        return (({"Real": 0.0, "Boolean": False, **OBJECT_FILL}).get(v.type, 0),) * size
    return tuple(parse_value(v, raw, v.qualified, allow_nonfinite=True) for raw in str(text).split())


def structural_sizes(variables: dict[str, Var], fmu: LoadedFmu) -> dict[str, list[str]]:
    """Structural parameter name -> the arrays whose dimensions it gives."""
    by_vr = {v.valueReference: v.name for v in fmu.md.modelVariables}
    sizes: dict[str, list[str]] = {}
    for mv in fmu.md.modelVariables:
        for d in getattr(mv, "dimensions", None) or ():
            if d.start is None:
                sizes.setdefault(by_vr[d.valueReference], []).append(mv.name)
    return sizes


def element_feedthrough(plan_vars: dict[str, Var], outs: dict) -> dict:
    """Output dependencies for array elements: an element depends on what its array does, and a dependency on
    an input array is one on each of its elements."""
    def expand(deps):
        if deps is None:
            return None
        return {e for d in deps for e in ([d] if not plan_vars[d].is_array else
                                          element_names(d, plan_vars[d].shape))}
    result = {name: expand(deps) for name, deps in outs.items()}
    for name, deps in list(result.items()):
        if plan_vars[name].is_array:
            result.update(dict.fromkeys(element_names(name, plan_vars[name].shape), deps))
    return result
