"""Build the coupling benchmarks of ssp/coupling/: their FMUs (native C and pythonfmu) and SSPs.

    python fmu_sources/coupling/build.py            # writes ssp/coupling/fmus/*.fmu and ssp/coupling/*.ssp

C FMUs (linux64 binaries, compiled with gcc; the sources are inside each FMU under sources/):
- MassA, MassB: the test suite's two-mass oscillator halves (tests/fmus_c/MassA.c, MassB.c with the shared
  FMI 2.0 framework and oscillator_math.h, built by tests/fmu_factory.py), both saving their FMU state;
- Affine: y = a u + b + c sin(w t) (fmu_sources/coupling/c/Affine.c), saving its state.
pythonfmu FMUs PyMassA, PyMassB, PyAffine: the same models in Python (fmu_sources/coupling/Py*.py), with
FMU state (uavsim/fmi.py's StateMixin, bundled as cosim_fmi.py).

The parameters come from ssp/coupling/oscillator_exact.py, which also holds the closed forms.
"""
from __future__ import annotations

import importlib.util
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


def build_c(dest: Path) -> dict[str, Path]:
    import fmu_factory as ff
    ff.VARIANT_MODELS["Affine"] = ff.CModel(
        name="Affine", description="y = a u + b + c sin(w t) (direct feedthrough)",
        variables=[ff._param("a", 0.5, "gain of the input"), ff._param("b", 1.0, "offset"),
                   ff._param("c", 0.0, "amplitude of the forcing"), ff._param("w", 1.0, "angular frequency"),
                   ff._input("u", 0.0, "input"), ff._output("y", "a u + b + c sin(w t)")],
        output_deps={"y": ["u"]}, versions_kinds={(2, "cs")}, source=str(HERE / "c" / "Affine.c"),
        saves_state=True)
    from fmu_sources.reproducible import make_reproducible
    return {m: make_reproducible(ff.build_c_fmu(m, dest), derive_guid=False) for m in ("MassA", "MassB", "Affine")}


def build_py(dest: Path) -> dict[str, Path]:
    import fmu_factory as ff
    from pythonfmu.builder import FmuBuilder
    out = {}
    with tempfile.TemporaryDirectory(prefix="coupling_py_") as tmp:
        stage = Path(tmp)
        shutil.copy2(REPO / "fmu_sources" / "uavsim" / "fmi.py", stage / "cosim_fmi.py")
        for name in ("PyMassA", "PyMassB", "PyAffine"):
            shutil.copy2(HERE / f"{name}.py", stage / f"{name}.py")
        sys.path.insert(0, str(stage))
        try:
            for name in ("PyMassA", "PyMassB", "PyAffine"):
                extra = [stage / "cosim_fmi.py"] + ([stage / "PyMassA.py"] if name != "PyMassA" else [])
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
    return written


def main() -> int:
    dest = OUT / "fmus"
    dest.mkdir(parents=True, exist_ok=True)
    fmus = {**build_c(dest), **build_py(dest)}
    for p in fmus.values():
        print(f"built {p}")
    for p in build_ssps(fmus):
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
