"""Build the small test FMUs used by cosim-master's test suite.

Two families:

* ``build_c_fmu(model, out_dir, fmi_version=2, kind="cs")`` -- our own C
  implementation of the FMI 2.0 (Co-Simulation or Model Exchange) and FMI 3.0
  (Co-Simulation) APIs (``tests/fmus_c/fmi2_framework.c`` /
  ``fmi3_framework.c``) plus one small C file per model with the equations
  (``tests/fmus_c/<Model>.c``).  The variable list below is the single source
  of truth: it produces both ``modelDescription.xml`` and the C header
  ``model_vars.h`` (value references, start values, settability), so the two
  can never disagree.  Compiled with gcc against the FMI headers shipped in
  fmpy (``<fmpy>/c-code``).
* ``build_python_fmu(model, out_dir)`` -- pythonfmu FMUs from
  ``tests/fmus_py/<Model>.py`` via ``pythonfmu build``.  pythonfmu 0.7 writes
  ``<Unknown index=".."/>`` without ``dependencies`` (i.e. "depends on every
  known") and no ``<InitialUnknowns>``; we post-process the generated
  modelDescription.xml from the ``OUTPUT_DEPENDENCIES`` dict declared in each
  model class so that the Python FMUs declare exactly the same
  ModelStructure as their C twins.

C models (variable names are part of the contract with the master's tests):

=============  ======================  =========================================
model          kinds                   variables
=============  ======================  =========================================
MassA          FMI2 CS                 m=1, k=1, x0=1, v0=0 (params), F (in),
                                       x, v (out, no feedthrough)
MassB          FMI2 CS                 m=1, k=1, kc=1, x0=0, v0=0 (params),
                                       x_in (in), x, v (out), F=kc*(x-x_in)
                                       (out, feedthrough from x_in)
Integrator     FMI2 CS, FMI3 CS        a=0, x0=0 (params), u (in), y (out)
Gain           FMI2 CS                 k=1 (param), u (in), y=k*u (out, feedthrough)
Oscillator     FMI2 ME                 m=1, k=1 (params), u (in),
                                       x=1, v=0 (states/outputs), der_x, der_v
Faulty         FMI2 CS                 fail_time=0.5 (param), mode=1 (Integer
                                       param), y=time (out)
=============  ======================  =========================================
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional
from xml.sax.saxutils import quoteattr

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "fmus_c"
PY_DIR = HERE / "fmus_py"

GENERATION_TOOL = "cosim-master tests/fmu_factory.py"


def fmi_headers_dir() -> Path:
    """Directory with fmi2Functions.h / fmi3Functions.h shipped with fmpy."""
    import fmpy

    return Path(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))


# ---------------------------------------------------------------------------
# model specifications


@dataclass
class Var:
    name: str
    type: str  # "Real" | "Integer" | "Boolean" | "String"
    causality: str  # parameter | input | output | local
    variability: str  # fixed | tunable | discrete | continuous
    initial: Optional[str] = None  # exact | approx | calculated | None
    start: Any = None
    description: str = ""
    derivative_of: Optional[str] = None  # ME: this variable is der(<name>)


@dataclass
class CModel:
    name: str
    description: str
    variables: list[Var]
    # output name -> list of names of the knowns it depends on
    # (None = omit the attribute, i.e. "depends on all knowns")
    output_deps: dict[str, Optional[list[str]]]
    versions_kinds: set[tuple[int, str]]
    # ME: derivative name -> dependencies
    derivative_deps: dict[str, Optional[list[str]]] = field(default_factory=dict)
    source: Optional[str] = None  # C file, defaults to <name>.c
    # FMI functions the library does not export, and functions exported under another name only (new name ->
    # the framework's function): FMUs of tools that predate the final FMI 2.0 names
    hidden_functions: tuple[str, ...] = ()
    renamed_functions: dict[str, str] = field(default_factory=dict)
    # FMI 2.0 get/set/free FMU state work (the framework copies the model data; canGetAndSetFMUstate="true"):
    # what iterative coupling's rollback needs. Off for the others, whose tests expect a refusal.
    saves_state: bool = False
    # FMI 3.0 event mode and early return (hasEventMode, mightReturnEarlyFromDoStep; fmi3_framework.c built with
    # FW_EVENT_MODE): the model steps with model_step_to_event and model_update_discrete
    event_mode: bool = False

    @property
    def c_source(self) -> Path:
        return C_DIR / (self.source or f"{self.name}.c")


def _param(name, start, desc="", typ="Real", variability="fixed"):
    return Var(name, typ, "parameter", variability, "exact", start, desc)


def _input(name, start=0.0, desc="", typ="Real"):
    variability = "continuous" if typ == "Real" else "discrete"
    return Var(name, typ, "input", variability, None, start, desc)


def _output(name, desc="", typ="Real"):
    variability = "continuous" if typ == "Real" else "discrete"
    return Var(name, typ, "output", variability, "calculated", None, desc)


C_MODELS: dict[str, CModel] = {
    "MassA": CModel(
        name="MassA",
        description="Mass m on a wall spring k driven by the coupling force F: m x'' = -k x + F; "
        "doStep is exact for F held constant.",
        variables=[
            _param("m", 1.0, "mass"),
            _param("k", 1.0, "wall spring stiffness"),
            _param("x0", 1.0, "initial position"),
            _param("v0", 0.0, "initial velocity"),
            _input("F", 0.0, "coupling force acting on the mass"),
            _output("x", "position"),
            _output("v", "velocity"),
        ],
        output_deps={"x": [], "v": []},
        versions_kinds={(2, "cs")},
        saves_state=True,
    ),
    "MassB": CModel(
        name="MassB",
        description="Mass m on a wall spring k, coupled to mass 1 by spring kc: "
        "m x'' = -(k+kc) x + kc x_in; F = kc (x - x_in) is the force on mass 1; "
        "doStep is exact for x_in held constant.",
        variables=[
            _param("m", 1.0, "mass"),
            _param("k", 1.0, "wall spring stiffness"),
            _param("kc", 1.0, "coupling spring stiffness"),
            _param("x0", 0.0, "initial position"),
            _param("v0", 0.0, "initial velocity"),
            _input("x_in", 0.0, "position of mass 1"),
            _output("x", "position"),
            _output("v", "velocity"),
            _output("F", "force of the coupling spring on mass 1: kc (x - x_in)"),
        ],
        # F has direct feedthrough from x_in (its dependency on the internal
        # state cannot be expressed: a Co-Simulation FMU exposes no states).
        output_deps={"x": [], "v": [], "F": ["x_in"]},
        versions_kinds={(2, "cs")},
        saves_state=True,
    ),
    "Integrator": CModel(
        name="Integrator",
        description="x' = a x + u, y = x; doStep performs exactly one explicit Euler step "
        "x += h (a x + u).",
        variables=[
            _param("a", 0.0, "linear feedback coefficient"),
            _param("x0", 0.0, "initial state"),
            _input("u", 0.0, "input"),
            _output("y", "state"),
        ],
        output_deps={"y": []},
        versions_kinds={(2, "cs"), (3, "cs")},
    ),
    "Gain": CModel(
        name="Gain",
        description="y = k u (direct feedthrough)",
        variables=[
            _param("k", 1.0, "gain"),
            _input("u", 0.0, "input"),
            _output("y", "k * u"),
        ],
        output_deps={"y": ["u"]},
        versions_kinds={(2, "cs")},
    ),
    "Oscillator": CModel(
        name="Oscillator",
        description="Model Exchange harmonic oscillator m x'' = -k x + u",
        variables=[
            _param("m", 1.0, "mass"),
            _param("k", 1.0, "spring stiffness"),
            _input("u", 0.0, "external force"),
            Var("x", "Real", "output", "continuous", "exact", 1.0, "position (state)"),
            Var("v", "Real", "output", "continuous", "exact", 0.0, "velocity (state)"),
            Var("der_x", "Real", "local", "continuous", "calculated", None, "der(x)", derivative_of="x"),
            Var("der_v", "Real", "local", "continuous", "calculated", None, "der(v)", derivative_of="v"),
        ],
        output_deps={"x": ["x"], "v": ["v"]},
        derivative_deps={"der_x": ["v"], "der_v": ["x", "u"]},
        versions_kinds={(2, "me")},
    ),
    "Faulty": CModel(
        name="Faulty",
        description="y = time; the first doStep with t + h > fail_time fails according to mode "
        "(0 none, 1 error, 2 discard, 3 abort(), 4 segfault, 5 hang, 6 sleep 20 ms and log when)",
        variables=[
            _param("fail_time", 0.5, "the first step ending after this time fails"),
            _param("mode", 1, "0 no failure, 1 error, 2 discard, 3 crash (abort), 4 segfault, 5 hang, 6 sleep",
                   typ="Integer"),
            _output("y", "simulation time"),
        ],
        output_deps={"y": []},
        versions_kinds={(2, "cs")},
    ),
}

# FMI 2.0's optional functions (capability flags canGetAndSetFMUstate, canSerializeFMUstate,
# providesDirectionalDerivative)
FMI2_OPTIONAL_FUNCTIONS = ("fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate", "fmi2SerializedFMUstateSize",
                           "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate", "fmi2GetDirectionalDerivative")
# FMUs built on request (build_c_fmu) and not among the fixture's keys, which the factory's own tests list and
# check as complete FMUs without features: FMUs with deliberate defects, and models for one feature's tests
VARIANT_MODELS: dict[str, CModel] = {}
VARIANT_MODELS["GainPreRelease"] = CModel(
    name="GainPreRelease",
    description="y = k u, as an FMI 2.0 release-candidate exporter (JModelica.org 1.15) builds it: no FMU state or "
    "directional derivative functions but fmi2DeSerializeFMUstate, spelled fmi2DeserializeFMUstate",
    variables=C_MODELS["Gain"].variables,
    output_deps={"y": ["u"]},
    versions_kinds={(2, "cs")},
    source="Gain.c",
    hidden_functions=FMI2_OPTIONAL_FUNCTIONS,
    renamed_functions={"fmi2DeserializeFMUstate": "fmi2DeSerializeFMUstate"},
)

VARIANT_MODELS["Ball"] = CModel(
    name="Ball",
    description="A bouncing ball, its flight integrated exactly: h' = v, v' = -g; at h = 0 falling, v := -e v "
    "(FMI 3.0 event mode and early return; tests/fmus_c/Ball.c)",
    variables=[
        _param("g", 9.81, "gravity"),
        _param("e", 0.5, "coefficient of restitution"),
        _param("h0", 1.0, "initial height"),
        _param("v0", 0.0, "initial speed (upwards)"),
        _param("v_min", 1e-3, "a slower rebound leaves the ball on the ground"),
        _param("max_bounces", 0, "the simulation ends at this bounce (0: never)", typ="Integer"),
        _output("h", "height"),
        _output("v", "speed (upwards)"),
        Var("bounces", "Integer", "output", "discrete", "calculated", None, "bounces so far"),
        Var("t_bounce", "Real", "output", "discrete", "calculated", None, "time of the last bounce (-1: none)"),
        Var("on_ground", "Boolean", "output", "discrete", "calculated", None, "resting on the ground"),
        Var("importer_updates", "Integer", "output", "discrete", "calculated", None,
            "event iteration passes the importer asked for (fmi3UpdateDiscreteStates)"),
    ],
    output_deps={"h": [], "v": [], "bounces": [], "t_bounce": [], "on_ground": [], "importer_updates": []},
    versions_kinds={(3, "cs")},
    event_mode=True,
)

PY_MODELS = ("MassA", "MassB", "Integrator", "Gain", "Faulty", "Types")


# ---------------------------------------------------------------------------
# helpers


def _fmt(value: Any, typ: str) -> str:
    if typ == "Boolean":
        return "true" if value else "false"
    if typ == "Real":
        return repr(float(value))
    if typ == "Integer":
        return str(int(value))
    return str(value)


def _guid(*parts: str) -> str:
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master-test/" + "/".join(parts))) + "}"


def _source_digest(spec: CModel, fmi_version: int) -> str:
    h = hashlib.sha256()
    for p in (C_DIR / "model_api.h", C_DIR / f"fmi{fmi_version}_framework.c", spec.c_source):
        h.update(p.read_bytes())
    for extra in sorted(C_DIR.glob("*.h")):
        h.update(extra.read_bytes())
    return h.hexdigest()[:16]


def _variables_for(spec: CModel, fmi_version: int) -> list[Var]:
    variables = list(spec.variables)
    if fmi_version == 3:
        variables.insert(0, Var("time", "Real", "independent", "continuous", None, None, "simulation time"))
    return variables


def _set_mode(v: Var) -> str:
    if v.causality == "input" or (v.causality == "parameter" and v.variability == "tunable"):
        return "SET_ALWAYS"
    if v.causality == "parameter" or v.initial in ("exact", "approx"):
        return "SET_BEFORE_RUN"
    return "SET_NEVER"


def _c_header(spec: CModel, variables: list[Var], guid: str, kind: str) -> str:
    n = len(variables)
    ctype = {"Real": "T_REAL", "Integer": "T_INTEGER", "Boolean": "T_BOOLEAN", "String": "T_STRING"}

    def arr(ctype_, name, values):
        return f"static const {ctype_} {name}[{n}] __attribute__((unused)) = {{{', '.join(values)}}};"

    real = [repr(float(v.start)) if (v.type == "Real" and v.start is not None) else "0.0" for v in variables]
    ints = [str(int(v.start)) if (v.type == "Integer" and v.start is not None) else "0" for v in variables]
    bools = [("1" if v.start else "0") if v.type == "Boolean" else "0" for v in variables]
    strs = [
        ('"' + str(v.start).replace("\\", "\\\\").replace('"', '\\"') + '"')
        if (v.type == "String" and v.start is not None)
        else "NULL"
        for v in variables
    ]
    states = [v.derivative_of for v in variables if v.derivative_of]
    names = [v.name for v in variables]
    state_vrs = [str(names.index(s)) for s in states] or ["0"]
    der_vrs = [str(i) for i, v in enumerate(variables) if v.derivative_of] or ["0"]
    lines = [
        "/* generated by tests/fmu_factory.py -- do not edit */",
        "#ifndef MODEL_VARS_H",
        "#define MODEL_VARS_H",
        "#include <stddef.h>",
        f'#define MODEL_NAME "{spec.name}"',
        f'#define MODEL_GUID "{guid}"',
        f"#define MODEL_SUPPORTS_CS {1 if kind == 'cs' else 0}",
        f"#define MODEL_SUPPORTS_ME {1 if kind == 'me' else 0}",
        f"#define NVARS {n}",
    ]
    lines += [f"#define VR_{v.name} {i}" for i, v in enumerate(variables)]
    lines += [
        f"static const int VAR_TYPE[{n}] __attribute__((unused)) = {{{', '.join(ctype[v.type] for v in variables)}}};",
        f"static const int VAR_SET_MODE[{n}] __attribute__((unused)) = {{{', '.join(_set_mode(v) for v in variables)}}};",
        arr("double", "START_REAL", real),
        arr("int", "START_INT", ints),
        arr("int", "START_BOOL", bools),
        arr("char *const", "START_STRING", strs),
        f"#define N_STATES {len(states)}",
        f"static const int STATE_VRS[{max(1, len(states))}] __attribute__((unused)) = {{{', '.join(state_vrs)}}};",
        f"static const int DER_VRS[{max(1, len(states))}] __attribute__((unused)) = {{{', '.join(der_vrs)}}};",
        "#define N_EVENT_INDICATORS 0",
        "#endif",
        "",
    ]
    return "\n".join(lines)


def _deps_attr(deps: Optional[list[str]], index_of) -> str:
    if deps is None:
        return ""
    return f' dependencies="{" ".join(str(index_of(d)) for d in deps)}"'


def _fmi2_model_description(spec: CModel, variables: list[Var], guid: str, kind: str) -> str:
    names = [v.name for v in variables]

    def idx(name):  # 1-based index into ModelVariables
        return names.index(name) + 1

    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName="{spec.name}" guid="{guid}"'
        f" description={quoteattr(spec.description)} generationTool={quoteattr(GENERATION_TOOL)}"
        ' variableNamingConvention="structured"'
        f' numberOfEventIndicators="0">',
    ]
    if kind == "cs":
        out.append(
            f'  <CoSimulation modelIdentifier="{spec.name}" canHandleVariableCommunicationStepSize="true"'
            ' canNotUseMemoryManagementFunctions="true"'
            f' canGetAndSetFMUstate="{str(spec.saves_state).lower()}"'
            ' canSerializeFMUstate="false" canInterpolateInputs="false" maxOutputDerivativeOrder="0"/>'
        )
    else:
        out.append(
            f'  <ModelExchange modelIdentifier="{spec.name}" canNotUseMemoryManagementFunctions="true"'
            ' canGetAndSetFMUstate="false" canSerializeFMUstate="false"/>'
        )
    out += [
        "  <LogCategories>",
        '    <Category name="logStatusWarning"/>',
        '    <Category name="logStatusDiscard"/>',
        '    <Category name="logStatusError"/>',
        '    <Category name="logStatusFatal"/>',
        '    <Category name="logAll"/>',
        "  </LogCategories>",
        '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.01"/>',
        "  <ModelVariables>",
    ]
    for vr, v in enumerate(variables):
        attrs = f'name="{v.name}" valueReference="{vr}" causality="{v.causality}" variability="{v.variability}"'
        if v.initial is not None and not (v.causality == "input" and v.initial == "exact"):
            attrs += f' initial="{v.initial}"'
        if v.description:
            attrs += f" description={quoteattr(v.description)}"
        type_attrs = ""
        if v.start is not None:
            type_attrs += f' start="{_fmt(v.start, v.type)}"'
        if v.derivative_of:
            type_attrs += f' derivative="{idx(v.derivative_of)}"'
        out.append(f"    <ScalarVariable {attrs}>")
        out.append(f"      <{v.type}{type_attrs}/>")
        out.append("    </ScalarVariable>")
    out.append("  </ModelVariables>")
    out.append("  <ModelStructure>")
    outputs = [v for v in variables if v.causality == "output"]
    if outputs:
        out.append("    <Outputs>")
        for v in outputs:
            out.append(f'      <Unknown index="{idx(v.name)}"{_deps_attr(spec.output_deps.get(v.name), idx)}/>')
        out.append("    </Outputs>")
    ders = [v for v in variables if v.derivative_of]
    if ders:
        out.append("    <Derivatives>")
        for v in ders:
            out.append(f'      <Unknown index="{idx(v.name)}"{_deps_attr(spec.derivative_deps.get(v.name), idx)}/>')
        out.append("    </Derivatives>")
    initial_unknowns = [v for v in outputs if v.initial in ("approx", "calculated")]
    states = {v.derivative_of for v in ders}
    for v in variables:
        if (v.derivative_of or v.name in states) and v.initial in ("approx", "calculated") and v not in initial_unknowns:
            initial_unknowns.append(v)
    initial_unknowns.sort(key=lambda v: idx(v.name))
    if initial_unknowns:
        out.append("    <InitialUnknowns>")
        for v in initial_unknowns:
            out.append(f'      <Unknown index="{idx(v.name)}"/>')
        out.append("    </InitialUnknowns>")
    out.append("  </ModelStructure>")
    out.append("</fmiModelDescription>")
    return "\n".join(out) + "\n"


_FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


def _fmi3_model_description(spec: CModel, variables: list[Var], guid: str) -> str:
    names = [v.name for v in variables]

    def vr(name):
        return names.index(name)

    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="3.0" modelName="{spec.name}" instantiationToken="{guid}"'
        f" description={quoteattr(spec.description)} generationTool={quoteattr(GENERATION_TOOL)}"
        ' variableNamingConvention="structured">',
        f'  <CoSimulation modelIdentifier="{spec.name}" canHandleVariableCommunicationStepSize="true"'
        ' canGetAndSetFMUState="false" canSerializeFMUState="false"'
        f' hasEventMode="{str(spec.event_mode).lower()}" mightReturnEarlyFromDoStep="{str(spec.event_mode).lower()}"'
        ' providesIntermediateUpdate="false" maxOutputDerivativeOrder="0"/>',
        "  <LogCategories>",
        '    <Category name="logStatusWarning"/>',
        '    <Category name="logStatusDiscard"/>',
        '    <Category name="logStatusError"/>',
        '    <Category name="logStatusFatal"/>',
        '    <Category name="logAll"/>',
        "  </LogCategories>",
        '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.01"/>',
        "  <ModelVariables>",
    ]
    for i, v in enumerate(variables):
        tag = _FMI3_TYPE[v.type]
        attrs = f'name="{v.name}" valueReference="{i}" causality="{v.causality}" variability="{v.variability}"'
        if v.initial is not None and v.causality not in ("input", "independent"):
            attrs += f' initial="{v.initial}"'
        if v.description:
            attrs += f" description={quoteattr(v.description)}"
        if v.start is not None:
            attrs += f' start="{_fmt(v.start, v.type)}"'
        if v.type == "String":
            raise NotImplementedError("String variables are not supported in the FMI 3 test FMUs")
        out.append(f"    <{tag} {attrs}/>")
    out.append("  </ModelVariables>")
    out.append("  <ModelStructure>")
    outputs = [v for v in variables if v.causality == "output"]
    for v in outputs:
        deps = spec.output_deps.get(v.name)
        dep_attr = "" if deps is None else f' dependencies="{" ".join(str(vr(d)) for d in deps)}"'
        out.append(f'    <Output valueReference="{vr(v.name)}"{dep_attr}/>')
    for v in outputs:
        if v.initial in ("approx", "calculated"):
            out.append(f'    <InitialUnknown valueReference="{vr(v.name)}"/>')
    out.append("  </ModelStructure>")
    out.append("</fmiModelDescription>")
    return "\n".join(out) + "\n"


# FMI 1.0 co-simulation builds (tests/fmus_c/fmi1_framework.c) of models whose FMI 2.0 twins they must match.
# Built by key (build_by_key("c1:Gain", ...)) but not among available_keys(), the test_fmus fixture's keys:
# tests/test_fmu_factory.py checks those as FMI 2.0/3.0 FMUs; tests/master/fmi/test_fmi1.py builds and checks these.
FMI1_MODELS = ("Integrator", "Gain", "Faulty")
FMI1_KEYS = tuple(f"c1:{name}" for name in FMI1_MODELS)
for _name in FMI1_MODELS:
    C_MODELS[_name].versions_kinds.add((1, "cs"))


def _fmi1_variability(v: Var) -> str:
    """FMI 1.0 has no fixed/tunable parameters: both are variability "parameter" (causality internal)."""
    return "parameter" if v.causality == "parameter" else v.variability


def _fmi1_causality(v: Var) -> str:
    return {"parameter": "internal", "local": "internal"}.get(v.causality, v.causality)


def _fmi1_variable(spec: CModel, vr: int, v: Var) -> list[str]:
    attrs = (f'name="{v.name}" valueReference="{vr}" variability="{_fmi1_variability(v)}"'
             f' causality="{_fmi1_causality(v)}"')
    if v.description:
        attrs += f" description={quoteattr(v.description)}"
    type_attrs = f' start="{_fmt(v.start, v.type)}" fixed="true"' if v.start is not None else ""
    lines = [f"    <ScalarVariable {attrs}>", f"      <{v.type}{type_attrs}/>"]
    deps = spec.output_deps.get(v.name) if v.causality == "output" else None
    if deps is not None:  # FMI 1.0: without DirectDependency an output depends on every input
        lines += ["      <DirectDependency>", *[f"        <Name>{d}</Name>" for d in deps], "      </DirectDependency>"]
    return lines + ["    </ScalarVariable>"]


def _fmi1_model_description(spec: CModel, variables: list[Var], guid: str) -> str:
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="1.0" modelName="{spec.name}" modelIdentifier="{spec.name}"'
        f' guid="{guid}" description={quoteattr(spec.description)} generationTool={quoteattr(GENERATION_TOOL)}'
        ' variableNamingConvention="structured" numberOfContinuousStates="0" numberOfEventIndicators="0">',
        '  <DefaultExperiment startTime="0" stopTime="10"/>',
        "  <ModelVariables>",
    ]
    for vr, v in enumerate(variables):
        out += _fmi1_variable(spec, vr, v)
    out += [
        "  </ModelVariables>",
        "  <Implementation>",
        "    <CoSimulation_StandAlone>",
        '      <Capabilities canHandleVariableCommunicationStepSize="true" canHandleEvents="true"'
        ' canRejectSteps="false" canInterpolateInputs="false" maxOutputDerivativeOrder="0"'
        ' canRunAsynchronuously="false" canSignalEvents="false" canBeInstantiatedOnlyOncePerProcess="false"'
        ' canNotUseMemoryManagementFunctions="true"/>',
        "    </CoSimulation_StandAlone>",
        "  </Implementation>",
        "</fmiModelDescription>",
    ]
    return "\n".join(out) + "\n"


def _export_flags(spec: CModel, tmp: Path) -> list[str]:
    """Linker flags that leave out ``spec.hidden_functions`` and publish the framework's functions under
    ``spec.renamed_functions`` (a version script: a named symbol wins over the wildcard)."""
    if not (spec.hidden_functions or spec.renamed_functions):
        return []
    hidden = [*spec.hidden_functions, *spec.renamed_functions.values()]
    script = tmp / "exports.map"
    script.write_text("{ global: *; local: " + " ".join(f"{name};" for name in hidden) + " };\n")
    return [f"-Wl,--version-script={script}"] + [f"-Wl,--defsym={new}={old}"
                                                for new, old in spec.renamed_functions.items()]


def _zip_dir(src: Path, fmu: Path) -> None:
    tmp = fmu.with_name(fmu.name + f".tmp{os.getpid()}")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in sorted(src.rglob("*")):
            if f.is_file():
                zf.write(f, f.relative_to(src).as_posix())
    os.replace(tmp, fmu)  # atomic: concurrent builders never see half a zip


# ---------------------------------------------------------------------------
# public API


def build_c_fmu(model: str, out_dir: Path, fmi_version: int = 2, kind: str = "cs") -> Path:
    """Compile ``tests/fmus_c/<model>.c`` into ``out_dir/<model>.fmu``.

    fmi_version 2 supports kind "cs" and "me" (as declared per model in
    ``C_MODELS``); fmi_version 3 supports kind "cs".
    """
    spec = C_MODELS.get(model) or VARIANT_MODELS.get(model)
    if spec is None:
        raise KeyError(f"unknown C model {model!r}; known: {sorted(C_MODELS)} and {sorted(VARIANT_MODELS)}")
    if (fmi_version, kind) not in spec.versions_kinds:
        raise ValueError(f"{model} is not available as FMI {fmi_version} {kind!r} ({sorted(spec.versions_kinds)})")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    variables = _variables_for(spec, fmi_version)
    guid = _guid(model, str(fmi_version), kind, _source_digest(spec, fmi_version))
    if fmi_version == 1:
        md = _fmi1_model_description(spec, variables, guid)
        platform_dir = "linux64"
    elif fmi_version == 2:
        md = _fmi2_model_description(spec, variables, guid, kind)
        platform_dir = "linux64"
    else:
        md = _fmi3_model_description(spec, variables, guid)
        platform_dir = "x86_64-linux"
    if sys.platform != "linux":
        raise RuntimeError("the C test FMUs are only built for Linux (x86_64)")
    header = _c_header(spec, variables, guid, kind)
    fmu = out_dir / f"{model}.fmu"
    cached = _cached_fmu(model, fmi_version, kind, spec, md, header)
    if cached is not None and cached.is_file():
        _copy_atomically(cached, fmu)
        return fmu

    with tempfile.TemporaryDirectory(prefix=f"fmu_{model}_") as tmp:
        tmp = Path(tmp)
        inc = tmp / "include"
        inc.mkdir()
        (inc / "model_vars.h").write_text(header)
        root = tmp / "fmu"
        bin_dir = root / "binaries" / platform_dir
        bin_dir.mkdir(parents=True)
        (root / "sources").mkdir()
        so = bin_dir / f"{spec.name}.so"
        cmd = [
            os.environ.get("CC", "gcc"),
            "-shared",
            "-fPIC",
            "-O2",
            "-std=gnu11",
            "-Wall",
            "-fvisibility=hidden",
            f"-I{fmi_headers_dir()}",
            f"-I{inc}",
            f"-I{C_DIR}",
            *(["-DFW_CAN_SAVE_STATE"] if spec.saves_state and fmi_version == 2 else []),
            *(["-DFW_EVENT_MODE"] if spec.event_mode and fmi_version == 3 else []),
            str(C_DIR / f"fmi{fmi_version}_framework.c"),
            str(spec.c_source),
            "-o",
            str(so),
            "-lm",
        ]
        cmd += _export_flags(spec, tmp)
        if fmi_version == 1:  # FMI 1.0 functions carry the model identifier as prefix (fmi1_framework.c)
            cmd.append(f"-DMODEL_IDENTIFIER={spec.name}")
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"gcc failed for {model} (FMI {fmi_version} {kind}):\n{proc.stderr}")
        (root / "modelDescription.xml").write_text(md, encoding="utf-8")
        for src in (C_DIR / "model_api.h", C_DIR / f"fmi{fmi_version}_framework.c", spec.c_source):
            shutil.copy2(src, root / "sources" / src.name)
        for hdr in C_DIR.glob("*.h"):
            shutil.copy2(hdr, root / "sources" / hdr.name)
        shutil.copy2(inc / "model_vars.h", root / "sources" / "model_vars.h")
        _zip_dir(root, fmu)
    if cached is not None:
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            _copy_atomically(fmu, cached)
        except OSError:
            pass        # a cache that cannot be written only costs the next session a build
    return fmu


# Built C test FMUs are kept between test sessions in a per-user cache, as the master keeps its own C builds
# (master/native_build.py): a gcc run per FMU and session (0.3 s each) was a visible share of the suite's CPU. The
# file name carries a hash of everything the FMU is made of: the model description and the generated header (the
# variables, their start values and the GUID, itself a hash of the C sources), the C sources and headers, the
# compiler flags and exports, the compiler, fmpy's FMI headers, and this file. An edit to any of them builds anew.
# COSIM_TEST_FMU_CACHE: the cache folder; "0" builds every FMU in every session.
def _fmu_cache_dir() -> Optional[Path]:
    env = os.environ.get("COSIM_TEST_FMU_CACHE")
    if env == "0":
        return None
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "cosim-master-tests" / "fmus"


def _cached_fmu(model: str, fmi_version: int, kind: str, spec: CModel, md: str, header: str) -> Optional[Path]:
    folder = _fmu_cache_dir()
    if folder is None:
        return None
    import fmpy
    cc = os.environ.get("CC", "gcc")
    cc_path = shutil.which(cc)
    cc_stat = os.stat(cc_path) if cc_path else None
    h = hashlib.sha256()
    for part in (model, str(fmi_version), kind, md, header, cc, str(cc_path),
                 f"{cc_stat.st_size}:{cc_stat.st_mtime_ns}" if cc_stat else "", fmpy.__version__,
                 str(fmi_headers_dir()), repr(sorted(spec.hidden_functions)), repr(sorted(spec.renamed_functions.items())),
                 repr((spec.saves_state, spec.event_mode))):
        h.update(part.encode() + b"\0")
    for src in (Path(__file__), C_DIR / f"fmi{fmi_version}_framework.c", spec.c_source, *sorted(C_DIR.glob("*.h"))):
        h.update(src.read_bytes() + b"\0")
    return folder / f"{model}-fmi{fmi_version}{kind}-{h.hexdigest()[:20]}.fmu"


def _copy_atomically(src: Path, dst: Path) -> None:
    tmp = dst.with_name(dst.name + f".tmp{os.getpid()}")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def _patch_python_model_description(xml_text: str, deps: dict[str, list[str]]) -> str:
    """Add Outputs dependencies and InitialUnknowns to a pythonfmu description."""
    from lxml import etree

    root = etree.fromstring(xml_text.encode("utf-8"))
    variables = root.find("ModelVariables").findall("ScalarVariable")
    names = [v.get("name") for v in variables]
    structure = root.find("ModelStructure")
    outputs = structure.find("Outputs")
    if outputs is not None:
        for unknown in outputs.findall("Unknown"):
            name = names[int(unknown.get("index")) - 1]
            if name in deps:
                unknown.set("dependencies", " ".join(str(names.index(d) + 1) for d in deps[name]))
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    initial = [
        i + 1
        for i, v in enumerate(variables)
        if v.get("causality") == "output" and v.get("initial", "calculated") in ("approx", "calculated")
    ]
    if initial:
        node = etree.SubElement(structure, "InitialUnknowns")
        for i in initial:
            etree.SubElement(node, "Unknown", index=str(i))
    etree.indent(root, space="  ")
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True).decode("utf-8")


def _load_output_dependencies(source: Path) -> Optional[dict[str, list[str]]]:
    import ast

    tree = ast.parse(source.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                if isinstance(target, ast.Name) and target.id == "OUTPUT_DEPENDENCIES":
                    return ast.literal_eval(node.value)
    return None


def build_python_fmu(model: str, out_dir: Path) -> Path:
    """Build ``tests/fmus_py/<model>.py`` with ``pythonfmu build``."""
    source = PY_DIR / f"{model}.py"
    if not source.exists():
        raise KeyError(f"unknown Python model {model!r}; known: {list(PY_MODELS)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f"pyfmu_{model}_") as tmp:
        tmp = Path(tmp)
        # build from a private copy: pythonfmu imports the script, and the
        # model directory must not end up on sys.path of the caller
        script = tmp / source.name
        shutil.copy2(source, script)
        build_dir = tmp / "build"
        exe = Path(sys.executable).with_name("pythonfmu")
        cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pythonfmu"]
        cmd += ["build", "-f", str(script), "-d", str(build_dir)]
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
        built = build_dir / f"{model}.fmu"
        if proc.returncode != 0 or not built.exists():
            raise RuntimeError(f"pythonfmu build failed for {model}:\n{proc.stdout}\n{proc.stderr}")
        deps = _load_output_dependencies(source)
        fmu = out_dir / f"{model}.fmu"
        tmp_fmu = tmp / "patched.fmu"
        with zipfile.ZipFile(built) as zin, zipfile.ZipFile(tmp_fmu, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml" and deps is not None:
                    data = _patch_python_model_description(data.decode("utf-8"), deps).encode("utf-8")
                zout.writestr(item, data)
        shutil.copy2(tmp_fmu, fmu.with_name(fmu.name + f".tmp{os.getpid()}"))
        os.replace(fmu.with_name(fmu.name + f".tmp{os.getpid()}"), fmu)
    return fmu


# key prefix -> (builder, kwargs)
_PREFIXES = {
    "c1": ("c", {"fmi_version": 1, "kind": "cs"}),
    "c2": ("c", {"fmi_version": 2, "kind": "cs"}),
    "me2": ("c", {"fmi_version": 2, "kind": "me"}),
    "c3": ("c", {"fmi_version": 3, "kind": "cs"}),
    "py": ("py", {}),
}


def available_keys() -> list[str]:
    keys = []
    for name, spec in C_MODELS.items():
        for version, kind in sorted(spec.versions_kinds - {(1, "cs")}):
            prefix = {(2, "cs"): "c2", (2, "me"): "me2", (3, "cs"): "c3"}[(version, kind)]
            keys.append(f"{prefix}:{name}")
    keys += [f"py:{m}" for m in PY_MODELS]
    return keys


def build_by_key(key: str, root: Path) -> Path:
    """Build the FMU for a key like ``"c2:MassA"`` into ``root/<prefix>/``."""
    prefix, _, model = key.partition(":")
    if prefix not in _PREFIXES or not model:
        raise KeyError(f"bad FMU key {key!r}; expected one of {available_keys()}")
    family, kwargs = _PREFIXES[prefix]
    out = Path(root) / prefix
    if family == "c":
        return build_c_fmu(model, out, **kwargs)
    return build_python_fmu(model, out)


if __name__ == "__main__":  # pragma: no cover - manual use
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("keys", nargs="*", help="e.g. c2:MassA py:Types (default: all)")
    ap.add_argument("-o", "--out", default="build/test_fmus")
    args = ap.parse_args()
    for k in args.keys or available_keys():
        print(build_by_key(k, Path(args.out)))
