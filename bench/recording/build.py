"""Build the recording benchmark's FMU: ``controlled_temperature.c`` (a stand-in for the 20-sim
ControlledTemperature cross-check FMU, whose binaries are Windows only) compiled with the system's C compiler
against the FMI 2.0 headers shipped with fmpy into ``ControlledTemperature.fmu`` (FMI 2.0 Co-Simulation,
120 Real variables; the list below is the C file's value references in order).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))     # run as a script too: the repository's bench
# the chain benchmark's builder already packs a one-file C FMU: its header folder and its zip are used here too
from bench.chain.build import _zip_dir, fmi_headers_dir  # noqa: E402

HERE = Path(__file__).resolve().parent
NSEG = 26

PARAMETERS = [("C", 0.5, "heat capacity of a segment [J/K]"), ("G", 8.0, "conductance between segments [W/K]"),
              ("G_amb", 0.35, "conductance of a segment to ambient [W/K]"), ("T_amb", 293.15, "ambient [K]"),
              ("T_set0", 313.15, "mean set-point [K]"), ("T_set_amp", 4.0, "set-point amplitude [K]"),
              ("period", 5.0, "set-point period [s]"), ("Kp", 40.0, "controller gain [%/K]"),
              ("Ti", 0.8, "integral time [s]"), ("P_max", 200.0, "heater power [W]")]
LOCALS = [("controller.T_set", "local"), ("controller.error", "local"), ("controller.integral", "local"),
          ("controller.u", "output"), ("heater.P", "output"), ("sensor.T", "output")]
SEGMENT = ("T", "der_T", "q_in", "q_amb")


def variables() -> list[tuple]:
    """(name, causality, variability, initial, start) in value-reference order."""
    out = [(f"p.{n}", "parameter", "fixed", "exact", start) for n, start, _ in PARAMETERS]
    out += [(n, c, "continuous", "calculated", None) for n, c in LOCALS]
    out += [(f"rod.seg{i + 1}.{n}", "local", "continuous", "calculated", None) for i in range(NSEG) for n in SEGMENT]
    return out


def _model_description(guid: str) -> str:
    vs = variables()
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName="ControlledTemperature" guid="{guid}"'
             ' description="a heated rod under PI control: the recording benchmark\'s stand-in for 20-sim\'s'
             ' ControlledTemperature" generationTool="cosim-master bench/recording/build.py"'
             ' variableNamingConvention="structured" numberOfEventIndicators="0">',
             '  <CoSimulation modelIdentifier="ControlledTemperature" canHandleVariableCommunicationStepSize="true"'
             ' canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="false" canSerializeFMUstate="false"'
             ' canInterpolateInputs="false" maxOutputDerivativeOrder="0"/>',
             '  <DefaultExperiment startTime="0" stopTime="20" stepSize="0.0001"/>',
             "  <ModelVariables>"]
    for vr, (name, caus, var, init, start) in enumerate(vs):
        real = f'<Real start="{start!r}"/>' if start is not None else "<Real/>"
        lines += [f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="{caus}" variability="{var}"'
                  f' initial="{init}">', f"      {real}", "    </ScalarVariable>"]
    outputs = [k + 1 for k, v in enumerate(vs) if v[1] == "output"]
    unknowns = "".join(f'<Unknown index="{k}" dependencies=""/>' for k in outputs)
    lines += ["  </ModelVariables>", "  <ModelStructure>", f"    <Outputs>{unknowns}</Outputs>",
              f"    <InitialUnknowns>{unknowns}</InitialUnknowns>", "  </ModelStructure>",
              "</fmiModelDescription>", ""]
    return "\n".join(lines)


def build_fmu(out_dir) -> Path:
    """``out_dir/ControlledTemperature.fmu``, rebuilt on every call (it takes a second)."""
    if sys.platform != "linux":
        raise RuntimeError("the benchmark's C FMU is built for Linux x86_64 only")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    src = HERE / "controlled_temperature.c"
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master-bench-recording/" + src.read_text())) + "}"
    with tempfile.TemporaryDirectory(prefix="recording_fmu_") as tmp:
        root = Path(tmp) / "fmu"
        bindir = root / "binaries" / "linux64"
        bindir.mkdir(parents=True)
        (root / "sources").mkdir()
        cmd = [os.environ.get("CC", "cc"), "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Wextra",
               "-ffp-contract=off", f"-I{fmi_headers_dir()}", str(src), "-lm", "-o", str(bindir / "ControlledTemperature.so")]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"the C compiler failed:\n{' '.join(cmd)}\n{proc.stderr}")
        shutil.copy2(src, root / "sources" / src.name)
        (root / "modelDescription.xml").write_text(_model_description(guid), encoding="utf-8")
        fmu = out_dir / "ControlledTemperature.fmu"
        _zip_dir(root, fmu)
    return fmu


if __name__ == "__main__":
    print(build_fmu(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="recording_")))
