"""Write small hand-made SSP 1.0 packages for tests.

``write_ssp`` produces a zip (``.ssp``) with ``SystemStructure.ssd`` at the
root and the FMUs in ``resources/``.  The SSD uses the SSP 1.0 namespaces with
the customary prefixes ``ssd:``, ``ssc:``, ``ssv:`` (libcosim's parser looks
the elements up by these literal prefixed names).  Parameter values are
written either inline (``ssd:ParameterValues``) or as one
``resources/<component>.ssv`` file per component.  The step size is written
as the OSP annotation understood by libcosim
(``osp:FixedStepAlgorithm baseStepSize``) inside ``ssd:DefaultExperiment``.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any, Iterable, Optional
from xml.sax.saxutils import quoteattr

NS_SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
NS_SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
NS_SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
NS_OSP = "http://opensimulationplatform.com/SSP/OSPAnnotations"

_KIND = {"input": "input", "output": "output", "parameter": "parameter", "calculatedParameter": "calculatedParameter"}
_SSC_TYPE = {
    "Real": "Real",
    "Float64": "Real",
    "Float32": "Real",
    "Integer": "Integer",
    "Int32": "Integer",
    "Boolean": "Boolean",
    "String": "String",
}


def _ssv_value(value: Any, typ: str) -> str:
    if typ == "Boolean":
        return f'<ssv:Boolean value="{"true" if value else "false"}"/>'
    if typ == "Integer":
        return f'<ssv:Integer value="{int(value)}"/>'
    if typ == "String":
        return f"<ssv:String value={quoteattr(str(value))}/>"
    return f'<ssv:Real value="{float(value)!r}"/>'


def _infer_type(value: Any) -> str:
    if isinstance(value, bool):
        return "Boolean"
    if isinstance(value, int):
        return "Integer"
    if isinstance(value, str):
        return "String"
    return "Real"


def _parameter_set(name: str, params: dict[str, Any], types: dict[str, str], indent: str) -> str:
    lines = [f'{indent}<ssv:ParameterSet version="1.0" name={quoteattr(name)}>', f"{indent}  <ssv:Parameters>"]
    for pname, value in params.items():
        typ = types.get(pname) or _infer_type(value)
        lines.append(f"{indent}    <ssv:Parameter name={quoteattr(pname)}>{_ssv_value(value, typ)}</ssv:Parameter>")
    lines += [f"{indent}  </ssv:Parameters>", f"{indent}</ssv:ParameterSet>"]
    return "\n".join(lines)


def write_ssp(
    path,
    components: dict[str, Any],
    connections: Iterable[tuple[str, str, str, str]] = (),
    parameters: Optional[dict[tuple[str, str], Any]] = None,
    start: float = 0.0,
    stop: float = 10.0,
    step: float = 0.01,
    system_name: str = "TestSystem",
    parameter_files: bool = False,
) -> Path:
    """Write a zipped SSP.

    components:  instance name -> FMU path (copied to ``resources/<file>``;
                 two instances may share one FMU file)
    connections: (source component, source variable, target component,
                 target variable)
    parameters:  (component, variable) -> value; the SSV type is taken from
                 the FMU's model description (Python type as fallback)
    parameter_files: write ``resources/<component>.ssv`` files referenced by
                 ``ssd:ParameterBinding source=...`` instead of inline values
    """
    from fmpy import read_model_description

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    parameters = dict(parameters or {})
    connections = list(connections)

    fmu_files: dict[str, Path] = {}  # resource name -> source path
    comp_source: dict[str, str] = {}
    comp_vars: dict[str, dict[str, Any]] = {}
    for name, fmu in components.items():
        fmu = Path(fmu)
        res_name = fmu.name
        if res_name in fmu_files and fmu_files[res_name].resolve() != fmu.resolve():
            res_name = f"{name}_{fmu.name}"
        fmu_files[res_name] = fmu
        comp_source[name] = f"resources/{res_name}"
        md = read_model_description(str(fmu))
        comp_vars[name] = {v.name: v for v in md.modelVariables}

    for (c, v) in parameters:
        if c not in components:
            raise KeyError(f"parameter for unknown component {c!r}")
        if v not in comp_vars[c]:
            raise KeyError(f"{c} has no variable {v!r}")
    for sc, sv, dc, dv in connections:
        for c, v in ((sc, sv), (dc, dv)):
            if c not in components or v not in comp_vars[c]:
                raise KeyError(f"connection endpoint {c}.{v} does not exist")

    ssv_files: dict[str, str] = {}
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<ssd:SystemStructureDescription xmlns:ssd="{NS_SSD}" xmlns:ssc="{NS_SSC}" xmlns:ssv="{NS_SSV}"'
        f' xmlns:osp="{NS_OSP}" version="1.0" name={quoteattr(system_name)}>',
        f"  <ssd:System name={quoteattr(system_name)}>",
        "    <ssd:Elements>",
    ]
    for name in components:
        variables = comp_vars[name]
        out.append(
            f"      <ssd:Component name={quoteattr(name)} type=\"application/x-fmu-sharedlibrary\""
            f" source={quoteattr(comp_source[name])}>"
        )
        out.append("        <ssd:Connectors>")
        for v in variables.values():
            kind = _KIND.get(v.causality)
            typ = _SSC_TYPE.get(v.type)
            if kind is None or typ is None:
                continue
            out.append(f"          <ssd:Connector name={quoteattr(v.name)} kind=\"{kind}\"><ssc:{typ}/></ssd:Connector>")
        out.append("        </ssd:Connectors>")
        comp_params = {v: val for (c, v), val in parameters.items() if c == name}
        if comp_params:
            types = {p: _SSC_TYPE.get(variables[p].type, "Real") for p in comp_params}
            if parameter_files:
                ssv_name = f"resources/{name}.ssv"
                ssv_files[ssv_name] = (
                    '<?xml version="1.0" encoding="UTF-8"?>\n'
                    + _parameter_set(f"{name}_parameters", comp_params, types, "").replace(
                        "<ssv:ParameterSet ", f'<ssv:ParameterSet xmlns:ssv="{NS_SSV}" ', 1
                    )
                    + "\n"
                )
                out.append("        <ssd:ParameterBindings>")
                out.append(
                    f"          <ssd:ParameterBinding type=\"application/x-ssp-parameter-set\" source={quoteattr(ssv_name)}/>"
                )
                out.append("        </ssd:ParameterBindings>")
            else:
                out += [
                    "        <ssd:ParameterBindings>",
                    "          <ssd:ParameterBinding>",
                    "            <ssd:ParameterValues>",
                    _parameter_set(f"{name}_parameters", comp_params, types, "              "),
                    "            </ssd:ParameterValues>",
                    "          </ssd:ParameterBinding>",
                    "        </ssd:ParameterBindings>",
                ]
        out.append("      </ssd:Component>")
    out.append("    </ssd:Elements>")
    if connections:
        out.append("    <ssd:Connections>")
        for sc, sv, dc, dv in connections:
            out.append(
                f"      <ssd:Connection startElement={quoteattr(sc)} startConnector={quoteattr(sv)}"
                f" endElement={quoteattr(dc)} endConnector={quoteattr(dv)}/>"
            )
        out.append("    </ssd:Connections>")
    out += [
        "  </ssd:System>",
        f'  <ssd:DefaultExperiment startTime="{float(start)!r}" stopTime="{float(stop)!r}">',
        "    <ssd:Annotations>",
        '      <ssc:Annotation type="com.opensimulationplatform">',
        f'        <osp:Algorithm><osp:FixedStepAlgorithm baseStepSize="{float(step)!r}"/></osp:Algorithm>',
        "      </ssc:Annotation>",
        "    </ssd:Annotations>",
        "  </ssd:DefaultExperiment>",
        "</ssd:SystemStructureDescription>",
        "",
    ]
    ssd = "\n".join(out)

    tmp = path.with_name(path.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("SystemStructure.ssd", ssd)
        for res_name, src in fmu_files.items():
            zf.write(src, f"resources/{res_name}")
        for name, text in ssv_files.items():
            zf.writestr(name, text)
    tmp.replace(path)
    return path
