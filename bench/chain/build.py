"""Build the chain benchmark's FMUs and SSPs.

* ``build_c_fmu(out_dir)``: bench/chain/lag.c compiled with gcc against the FMI 2.0 headers shipped with
  fmpy (``<fmpy>/c-code``) and bench/fmi2_stubs/fmi2_common.h (the stubs it shares with the recording
  benchmark's FMUs) into ``out_dir/Lag.fmu`` (FMI 2.0 Co-Simulation, binaries/linux64/Lag.so; both sources
  in sources/).
* ``build_python_fmu(out_dir)``: bench/chain/Lag.py through ``pythonfmu build``; its modelDescription.xml is
  patched to declare the same ModelStructure as the C twin (``y`` has no direct feedthrough, and is an
  initial unknown), which pythonfmu 0.7 does not write.
* ``build_chain_ssp(fmu, n, path, step, stop)``: n instances lag0..lag{n-1} of one FMU, lag{i-1}.y -> lag{i}.u,
  lag0.u unconnected and not declared as a
  connector (it keeps its start value 0), written with master.ssp.writer.SspBuilder (step size in
  our settings annotation and the OSP annotation).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

HERE = Path(__file__).resolve().parent
# the FMI 2.0 life cycle and unsupported-function stubs lag.c shares with the recording benchmark's FMUs
COMMON_HEADER = HERE.parent / "fmi2_stubs" / "fmi2_common.h"

# name, causality, variability, initial, start, description -- value reference = position (see lag.c)
VARIABLES = [
    ("T", "parameter", "fixed", "exact", 1.0, "time constant"),
    ("k", "parameter", "fixed", "exact", 1.0, "gain"),
    ("x0", "parameter", "fixed", "exact", 1.0, "initial state"),
    ("u", "input", "continuous", None, 0.0, "input"),
    ("y", "output", "continuous", "calculated", None, "state"),
]
VR = {v[0]: i for i, v in enumerate(VARIABLES)}


def fmi_headers_dir() -> Path:
    import fmpy
    return Path(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))


def _model_description(guid: str) -> str:
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName="Lag" guid="{guid}"'
        ' description="first-order lag x\' = (k u - x)/T, y = x; one explicit Euler step per doStep"'
        ' generationTool="cosim-master bench/chain/build.py" variableNamingConvention="structured"'
        ' numberOfEventIndicators="0">',
        '  <CoSimulation modelIdentifier="Lag" canHandleVariableCommunicationStepSize="true"'
        ' canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="false" canSerializeFMUstate="false"'
        ' canInterpolateInputs="false" maxOutputDerivativeOrder="0" canBeInstantiatedOnlyOncePerProcess="false"/>',
        '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.001"/>',
        "  <ModelVariables>",
    ]
    for vr, (name, caus, var, init, start, desc) in enumerate(VARIABLES):
        attrs = f'name="{name}" valueReference="{vr}" causality="{caus}" variability="{var}"'
        if init:
            attrs += f' initial="{init}"'
        attrs += f' description="{desc}"'
        real = f'<Real start="{start!r}"/>' if start is not None else "<Real/>"
        lines += [f"    <ScalarVariable {attrs}>", f"      {real}", "    </ScalarVariable>"]
    y = VR["y"] + 1
    lines += [
        "  </ModelVariables>",
        "  <ModelStructure>",
        f'    <Outputs><Unknown index="{y}" dependencies=""/></Outputs>',
        f'    <InitialUnknowns><Unknown index="{y}" dependencies=""/></InitialUnknowns>',
        "  </ModelStructure>",
        "</fmiModelDescription>",
        "",
    ]
    return "\n".join(lines)


def _zip_dir(src: Path, fmu: Path) -> None:
    tmp = fmu.with_name(fmu.name + f".tmp{os.getpid()}")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in sorted(src.rglob("*")):
            if f.is_file():
                zf.write(f, f.relative_to(src).as_posix())
    os.replace(tmp, fmu)


def build_c_fmu(out_dir) -> Path:
    if sys.platform != "linux":
        raise RuntimeError("the benchmark's C FMU is built for Linux x86_64 only")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    src = HERE / "lag.c"
    common = COMMON_HEADER
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master-bench-chain/" + src.read_text()
                                + common.read_text())) + "}"
    with tempfile.TemporaryDirectory(prefix="chain_c_") as tmp:
        root = Path(tmp) / "fmu"
        bindir = root / "binaries" / "linux64"
        bindir.mkdir(parents=True)
        (root / "sources").mkdir()
        cmd = [os.environ.get("CC", "gcc"), "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Wextra",
               "-ffp-contract=off", "-fvisibility=default", f"-I{fmi_headers_dir()}", f"-I{common.parent}", str(src),
               "-o", str(bindir / "Lag.so")]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"gcc failed:\n{' '.join(cmd)}\n{proc.stderr}")
        for f in (src, common):
            shutil.copy2(f, root / "sources" / f.name)
        (root / "modelDescription.xml").write_text(_model_description(guid), encoding="utf-8")
        fmu = out_dir / "Lag.fmu"
        _zip_dir(root, fmu)
    return fmu


def _patch_pythonfmu_description(xml: bytes) -> bytes:
    """Declare y without direct feedthrough and as initial unknown, like the C FMU."""
    root = ET.fromstring(xml)
    names = [v.get("name") for v in root.find("ModelVariables").findall("ScalarVariable")]
    structure = root.find("ModelStructure")
    y = str(names.index("y") + 1)
    for unknown in structure.find("Outputs").findall("Unknown"):
        if unknown.get("index") == y:
            unknown.set("dependencies", "")
    for old in structure.findall("InitialUnknowns"):
        structure.remove(old)
    init = ET.SubElement(structure, "InitialUnknowns")
    ET.SubElement(init, "Unknown", index=y, dependencies="")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def build_python_fmu(out_dir) -> Path:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="chain_py_") as tmp:
        tmp = Path(tmp)
        script = tmp / "Lag.py"
        shutil.copy2(HERE / "Lag.py", script)
        exe = Path(sys.executable).with_name("pythonfmu")
        cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pythonfmu"]
        cmd += ["build", "-f", str(script), "-d", str(tmp / "out")]
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
        built = tmp / "out" / "Lag.fmu"
        if proc.returncode != 0 or not built.exists():
            raise RuntimeError(f"pythonfmu build failed:\n{proc.stdout}\n{proc.stderr}")
        fmu = out_dir / "Lag.fmu"
        part = fmu.with_name(fmu.name + f".tmp{os.getpid()}")
        with zipfile.ZipFile(built) as zin, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = _patch_pythonfmu_description(data)
                zout.writestr(item, data)
        os.replace(part, fmu)
    return fmu


def build_chain_ssp(fmu, n: int, path, step: float, stop: float) -> Path:
    """``fmu``: one FMU for every instance, or a list cycled over them (the mixed flavour)."""
    sys.path.insert(0, str(HERE.parent.parent))
    from master.ssp.writer import SspBuilder

    b = SspBuilder(name=f"chain{n}", stop=stop, step=step, algorithm="jacobi")
    conns = [("u", "input", "Real", None), ("y", "output", "Real", None)]
    for i in range(n):
        # lag0's input is unconnected and not declared as a connector at all: fmpy's SSP runner requires
        # every declared input to be connected, and so no master writes to it (it keeps its start value 0)
        b.add_component(f"lag{i}", fmu[i % len(fmu)] if isinstance(fmu, list) else fmu,
                        connectors=conns if i else conns[1:])
    for i in range(1, n):
        b.connect(f"lag{i - 1}", "y", f"lag{i}", "u")
    return b.write(path)


def build_all(build_dir, n: int, steps: int, step: float) -> dict:
    """Build both flavours; returns {flavour: {"fmu": Path, "ssp": Path}} or {flavour: {"error": str}}."""
    build_dir = Path(build_dir)
    out = {}
    for flavour, builder in (("c", build_c_fmu), ("py", build_python_fmu)):
        try:
            fmu = builder(build_dir / flavour)
            ssp = build_chain_ssp(fmu, n, build_dir / f"chain_{flavour}_{n}.ssp", step, steps * step)
            out[flavour] = {"fmu": fmu, "ssp": ssp}
        except Exception as exc:  # reported in the table, the other flavour still runs
            out[flavour] = {"error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"}
    # mixed: C and pythonfmu instances alternate along the chain (the same trajectory: the models are twins)
    if "error" in out["c"] or "error" in out["py"]:
        out["mix"] = {"error": "needs both flavours"}
    else:
        fmus = [out["c"]["fmu"], out["py"]["fmu"]]
        out["mix"] = {"fmu": fmus[0], "ssp": build_chain_ssp(fmus, n, build_dir / f"chain_mix_{n}.ssp", step,
                                                             steps * step)}
    return out


if __name__ == "__main__":
    print(build_all(HERE / "build", 10, 10000, 0.001))
