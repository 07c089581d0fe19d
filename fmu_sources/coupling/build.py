"""Build the coupling benchmarks of ssp/coupling/: their FMUs (native C and pythonfmu) and SSPs.

    python fmu_sources/coupling/build.py            # writes ssp/coupling/fmus/*.fmu and ssp/coupling/*.ssp

C FMUs (linux64 binaries, compiled with gcc; the sources are inside each FMU under sources/):
- MassA, MassB: the test suite's two-mass oscillator halves (tests/fmus_c/MassA.c, MassB.c with the shared
  FMI 2.0 framework and oscillator_math.h, built by tests/fmu_factory.py), both saving their FMU state;
- Affine: y = a u + b + c sin(w t) (fmu_sources/coupling/c/Affine.c), saving its state;
- Affine2: y = A u + b + (c sin(w t), 0) with two inputs and outputs (c/Affine2.c), saving its state.
- MassAInterp, MassBInterp: the same halves with canInterpolateInputs (fmi2SetRealInputDerivatives, orders 1
  and 2, integrated exactly) and maxOutputDerivativeOrder 1 (fmi2GetRealOutputDerivatives), self-contained
  (fmu_sources/coupling/c/MassInterp.c, one source built twice).
pythonfmu FMUs PyMassA, PyMassB, PyAffine: the same models in Python (fmu_sources/coupling/Py*.py), with
FMU state (uavsim/fmi.py's StateMixin, bundled as cosim_fmi.py).

The parameters come from ssp/coupling/oscillator_exact.py, which also holds the closed forms.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
OUT = REPO / "ssp" / "coupling"
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO))


def _exact():
    spec = importlib.util.spec_from_file_location("oscillator_exact", OUT / "oscillator_exact.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _quarter_car():
    return _module("quarter_car_exact")


def _module(name: str):
    spec = importlib.util.spec_from_file_location(name, OUT / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def build_c(dest: Path) -> dict[str, Path]:
    import fmu_factory as ff
    ff.VARIANT_MODELS["Affine"] = ff.CModel(
        name="Affine", description="y = a u + b + c sin(w t) (direct feedthrough)",
        variables=[ff._param("a", 0.5, "gain of the input"), ff._param("b", 1.0, "offset"),
                   ff._param("c", 0.0, "amplitude of the forcing"), ff._param("w", 1.0, "angular frequency"),
                   ff._input("u", 0.0, "input"), ff._output("y", "a u + b + c sin(w t)")],
        output_deps={"y": ["u"]}, versions_kinds={(2, "cs")}, source=str(HERE / "c" / "Affine.c"),
        saves_state=True)
    ff.VARIANT_MODELS["Affine2"] = ff.CModel(
        name="Affine2", description="y = A u + b + (c sin(w t), 0), two inputs and two outputs (direct feedthrough)",
        variables=[ff._param("a11", 0.5, "A[1,1]"), ff._param("a12", 0.0, "A[1,2]"), ff._param("a21", 0.0, "A[2,1]"),
                   ff._param("a22", 0.5, "A[2,2]"), ff._param("b1", 0.0, "offset of y1"),
                   ff._param("b2", 0.0, "offset of y2"), ff._param("c", 0.0, "amplitude of the forcing of y1"),
                   ff._param("w", 1.0, "angular frequency"), ff._input("u1", 0.0, "first input"),
                   ff._input("u2", 0.0, "second input"), ff._output("y1", "a11 u1 + a12 u2 + b1 + c sin(w t)"),
                   ff._output("y2", "a21 u1 + a22 u2 + b2")],
        output_deps={"y1": ["u1", "u2"], "y2": ["u1", "u2"]}, versions_kinds={(2, "cs")},
        source=str(HERE / "c" / "Affine2.c"), saves_state=True)
    from fmu_sources.reproducible import make_reproducible
    return {m: make_reproducible(ff.build_c_fmu(m, dest), derive_guid=False)
            for m in ("MassA", "MassB", "Affine", "Affine2")}


INTERP_VARIABLES = {   # name, causality, description (value references in this order, as MassInterp.c's enums)
    "MassAInterp": [("m", "parameter", "mass"), ("k", "parameter", "wall spring stiffness"),
                    ("x0", "parameter", "initial position"), ("v0", "parameter", "initial velocity"),
                    ("F", "input", "coupling force acting on the mass"), ("x", "output", "position"),
                    ("v", "output", "velocity")],
    "MassBInterp": [("m", "parameter", "mass"), ("k", "parameter", "wall spring stiffness"),
                    ("kc", "parameter", "coupling spring stiffness"), ("x0", "parameter", "initial position"),
                    ("v0", "parameter", "initial velocity"), ("x_in", "input", "position of mass 1"),
                    ("x", "output", "position"), ("v", "output", "velocity"),
                    ("F", "output", "force of the coupling spring on mass 1: kc (x - x_in)")],
}
INTERP_START = {"MassAInterp": [1.0, 1.0, 1.0, 0.0, 0.0], "MassBInterp": [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]}


def _interp_model_description(name: str) -> str:
    from xml.sax.saxutils import quoteattr
    variables = INTERP_VARIABLES[name]
    rows = []
    for vr, (var, causality, description) in enumerate(variables):
        if causality == "parameter":
            attrs, real = ' variability="fixed" initial="exact"', f'<Real start="{INTERP_START[name][vr]!r}"/>'
        elif causality == "input":
            attrs, real = ' variability="continuous"', f'<Real start="{INTERP_START[name][vr]!r}"/>'
        else:
            attrs, real = ' variability="continuous" initial="calculated"', "<Real/>"
        rows.append(f'    <ScalarVariable name="{var}" valueReference="{vr}" causality="{causality}"{attrs}'
                    f' description={quoteattr(description)}>\n      {real}\n    </ScalarVariable>')
    index = {var: k + 1 for k, (var, _, _) in enumerate(variables)}
    inputs = [var for var, c, _ in variables if c == "input"]
    outputs = [(var, str(index[inputs[0]]) if var == "F" and name == "MassBInterp" else "")
               for var, c, _ in variables if c == "output"]
    unknowns = "\n".join(f'      <Unknown index="{index[v]}" dependencies="{d}"/>' for v, d in outputs)
    initial = "\n".join(f'      <Unknown index="{index[v]}"/>' for v, _ in outputs)
    side = "B" if name == "MassBInterp" else "A"
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="{name}" guid="{{00000000-0000-0000-0000-00000000000{side}}}" \
description="Mass{side} of the two-mass oscillator with inputs interpolated within the step \
(fmi2SetRealInputDerivatives, orders 1 and 2); doStep is exact for a quadratic input." \
generationTool="cosim-master fmu_sources/coupling/build.py" variableNamingConvention="structured" \
numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="true" \
canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="true" canSerializeFMUstate="false" \
canInterpolateInputs="true" maxOutputDerivativeOrder="1"/>
  <LogCategories>
    <Category name="logStatusError"/>
  </LogCategories>
  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.01"/>
  <ModelVariables>
{chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{unknowns}
    </Outputs>
    <InitialUnknowns>
{initial}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def build_interp(dest: Path) -> dict[str, Path]:
    """MassAInterp and MassBInterp from c/MassInterp.c (gcc; SIDE_B selects the half)."""
    import subprocess
    import fmu_factory as ff
    from fmu_sources.reproducible import make_reproducible
    source = HERE / "c" / "MassInterp.c"
    out = {}
    for name, side in (("MassAInterp", 0), ("MassBInterp", 1)):
        with tempfile.TemporaryDirectory(prefix=f"fmu_{name}_") as tmp:
            root = Path(tmp) / "fmu"
            (root / "binaries" / "linux64").mkdir(parents=True)
            (root / "sources").mkdir()
            cmd = [os.environ.get("CC", "gcc"), "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Werror",
                   f"-I{ff.fmi_headers_dir()}", f"-DSIDE_B={side}", str(source), "-o",
                   str(root / "binaries" / "linux64" / f"{name}.so"), "-lm"]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                raise RuntimeError(f"gcc failed for {name}:\n{proc.stderr}")
            shutil.copy2(source, root / "sources" / source.name)
            (root / "modelDescription.xml").write_text(_interp_model_description(name), encoding="utf-8")
            fmu = dest / f"{name}.fmu"
            with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
                for f in sorted(root.rglob("*")):
                    if f.is_file():
                        z.write(f, f.relative_to(root).as_posix())
            out[name] = make_reproducible(fmu, derive_guid=False)
    return out


#: the pythonfmu models and the other model files each imports (bundled into its FMU)
PY_MODELS = {"PyMassA": [], "PyMassB": ["PyMassA"], "PyAffine": ["PyMassA"], "PyWheel": [], "PyChassis": ["PyWheel"]}


def build_py(dest: Path) -> dict[str, Path]:
    import fmu_factory as ff
    from pythonfmu.builder import FmuBuilder
    out = {}
    with tempfile.TemporaryDirectory(prefix="coupling_py_") as tmp:
        stage = Path(tmp)
        shutil.copy2(REPO / "fmu_sources" / "uavsim" / "fmi.py", stage / "cosim_fmi.py")
        for name in PY_MODELS:
            shutil.copy2(HERE / f"{name}.py", stage / f"{name}.py")
        sys.path.insert(0, str(stage))
        try:
            for name in PY_MODELS:
                extra = [stage / "cosim_fmi.py"] + [stage / f"{d}.py" for d in PY_MODELS[name]]
                built = Path(FmuBuilder.build_FMU(stage / f"{name}.py", dest=stage / "build",
                                                  project_files=extra, canGetAndSetFMUstate=True))
                out[name] = _with_dependencies(built, HERE / f"{name}.py", dest / f"{name}.fmu", ff)
        finally:
            sys.path.remove(str(stage))
    return out


def _with_dependencies(built: Path, source: Path, fmu: Path, ff) -> Path:
    """The FMU with the output dependencies its script declares (pythonfmu writes none: every output would
    depend on every input, and the loop would look algebraic where it is not)."""
    deps = ff._load_output_dependencies(source)
    with zipfile.ZipFile(built) as zin, zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml" and deps is not None:
                data = ff._patch_python_model_description(data.decode("utf-8"), deps).encode("utf-8")
            zout.writestr(item, data)
    from fmu_sources.reproducible import make_reproducible
    return make_reproducible(fmu)


def build_ssps(fmus: dict[str, Path], out: Path = OUT) -> list[Path]:
    from master.ssp.writer import SspBuilder
    # every component's parameter set has the name the UAV SSPs use: Ecos applies the sets of one name per
    # init (init(parameter_set="scenario")), and with one set name per component it applied only one component's
    from uavstudy.build import PARAMETER_SET
    ex = _exact()
    osc, stiff = ex.OSCILLATOR, ex.STIFF

    def masses(p):
        return ({"m": p["m1"], "k": p["k1"], "x0": p["x10"], "v0": p["v10"]},
                {"m": p["m2"], "k": p["k2"], "kc": p["kc"], "x0": p["x20"], "v0": p["v20"]})

    written = []
    for suffix, a, b, affine in (("", "MassA", "MassB", "Affine"), ("_py", "PyMassA", "PyMassB", "PyAffine")):
        for name, p in (("oscillator_fd", osc), ("oscillator_stiff", stiff)):
            pa, pb = masses(p)
            sb = SspBuilder(name + suffix, stop=10.0, step=0.01, parameter_set=PARAMETER_SET)
            sb.add_component("A", fmus[a], params=pa).add_component("B", fmus[b], params=pb)
            sb.connect("A", "x", "B", "x_in").connect("B", "F", "A", "F")
            written.append(sb.write(out / f"{name}{suffix}.ssp"))
        # displacement-displacement: each side holds the coupling spring and reads the other's position
        pa, pb = masses(osc)
        sb = SspBuilder("oscillator_dd" + suffix, stop=10.0, step=0.01, parameter_set=PARAMETER_SET)
        sb.add_component("A", fmus[b], params={**pa, "kc": osc["kc"]}).add_component("B", fmus[b], params=pb)
        sb.connect("A", "x", "B", "x_in").connect("B", "x", "A", "x_in")
        written.append(sb.write(out / f"oscillator_dd{suffix}.ssp"))
        sb = SspBuilder("algebraic_loop" + suffix, stop=10.0, step=0.1, parameter_set=PARAMETER_SET)
        for comp, p in ex.LOOP.items():
            sb.add_component(comp, fmus[affine], params=p)
        sb.connect("L1", "y", "L2", "u").connect("L2", "y", "L1", "u")
        written.append(sb.write(out / f"algebraic_loop{suffix}.ssp"))
    if "Affine2" in fmus:
        # a loop of two values each way, where the coupling updates differ (loop2_exact.py)
        loop2 = _module("loop2_exact")
        sb = SspBuilder("algebraic_loop2", stop=10.0, step=0.1)
        for comp, p in loop2.LOOP2.items():
            sb.add_component(comp, fmus["Affine2"], params=p)
        for k in ("1", "2"):
            sb.connect("P", "y" + k, "Q", "u" + k).connect("Q", "y" + k, "P", "u" + k)
        written.append(sb.write(out / "algebraic_loop2.ssp"))
    if "PyChassis" in fmus:
        # the quarter car (Sadjina et al. 2017) with its power bond: the chassis' force (effort) into the wheel,
        # the wheel's velocity (flow) into the chassis; linear and progressive damping
        from master.ssp.power_bonds import power_bonds_annotation
        qc = _quarter_car()
        for name, chassis in (("quarter_car_linear", qc.CHASSIS), ("quarter_car_nonlinear", qc.NONLINEAR_CHASSIS)):
            sb = SspBuilder(name, stop=qc.STOP, step=0.01)
            sb.add_component("chassis", fmus["PyChassis"], params=chassis)
            sb.add_component("wheel", fmus["PyWheel"], params=qc.WHEEL)
            sb.connect("chassis", "F", "wheel", "F").connect("wheel", "v", "chassis", "v_in")
            sb.annotations.append(power_bonds_annotation(
                [("suspension", ("chassis", "F", "wheel", "F"), ("wheel", "v", "chassis", "v_in"))]))
            written.append(sb.write(out / f"{name}.ssp"))
    if "MassAInterp" in fmus:
        # the force-displacement oscillator with the interpolating halves (input derivatives, docs/coupling.md)
        pa, pb = masses(osc)
        sb = SspBuilder("oscillator_fd_interp", stop=10.0, step=0.01)
        sb.add_component("A", fmus["MassAInterp"], params=pa).add_component("B", fmus["MassBInterp"], params=pb)
        sb.connect("A", "x", "B", "x_in").connect("B", "F", "A", "F")
        written.append(sb.write(out / "oscillator_fd_interp.ssp"))
    return written


def main() -> int:
    dest = OUT / "fmus"
    dest.mkdir(parents=True, exist_ok=True)
    fmus = {**build_c(dest), **build_interp(dest), **build_py(dest)}
    for p in fmus.values():
        print(f"built {p}")
    for p in build_ssps(fmus):
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
