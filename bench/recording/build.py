"""Build the recording benchmark's FMUs, stand-ins for the 20-sim ControlledTemperature cross-check FMU (whose
binaries are Windows only), compiled with the system's C compiler against the FMI 2.0 headers shipped with fmpy
(FMI 2.0 Co-Simulation):

* ``build_fmu(out_dir)``: ``controlled_temperature.c`` into ``ControlledTemperature.fmu``, the harsh case: 120
  Real variables, one value reference each (``variables()``, in value-reference order), 110 of them changing
  in every step with full-precision digits.
* ``build_fmu(out_dir, "20sim")``: ``controlled_temperature_20sim.c`` into ``ControlledTemperature20sim.fmu``,
  with the original's variable make-up (``LAYOUT_20SIM``): 118 Reals over 50 value references (most variables
  are aliases of another), 19 of them parameters, 2 Booleans.
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


# The 20-sim FMU's make-up, value reference by value reference (read from its modelDescription.xml; the names are
# ours): (value reference, name, how many variables alias it, causality, variability, start). The quantities are
# controlled_temperature_20sim.c's: constant ones (ground potentials, the supply, the ambient), the switch's (they
# change at its events only), the ramped set-point, and the ones that change in every step.
LAYOUT_20SIM = [
    (0, "heater.C", 1, "parameter", "tunable", 0.1), (1, "heater.T0", 1, "parameter", "tunable", 298.0),
    (2, "controller.band", 1, "parameter", "tunable", 2.0), (3, "setpoint.slope", 1, "parameter", "tunable", 4.16667),
    (4, "setpoint.start", 1, "parameter", "tunable", 8.0), (5, "setpoint.stop", 1, "parameter", "tunable", 16.0),
    (6, "setpoint.offset", 1, "parameter", "tunable", 298.15), (7, "switch.R1", 1, "parameter", "tunable", 5.0e6),
    (8, "switch.R2", 1, "parameter", "tunable", 5.0e6), (9, "switch.R_on", 1, "parameter", "tunable", 1.0e-5),
    (10, "switch.R_off", 1, "parameter", "tunable", 100000.0), (11, "switch.threshold", 1, "parameter", "tunable", 0.5),
    (12, "ambient.T", 1, "parameter", "tunable", 293.15), (13, "wall.G", 1, "parameter", "tunable", 0.1),
    (14, "heater.R_ref", 1, "parameter", "tunable", 10.0), (15, "heater.T_ref", 1, "parameter", "tunable", 293.15),
    (16, "heater.alpha", 1, "parameter", "tunable", 0.004), (17, "supply.U", 1, "parameter", "tunable", 10.0),
    (18, "heater.Q_int0", 1, "parameter", "fixed", 0.0),
    (19, "ground.v", 5, "local", "continuous", None), (20, "ground.i", 1, "local", "continuous", None),
    (21, "heater.T", 12, "local", "continuous", None), (22, "heater.E", 1, "local", "continuous", None),
    (24, "controller.on", 3, "local", "continuous", None), (25, "setpoint.T", 5, "local", "continuous", None),
    (26, "switch.ground1.v", 3, "local", "continuous", None), (27, "switch.ground2.v", 3, "local", "continuous", None),
    (28, "supply.i", 6, "local", "continuous", None), (29, "switch.R1.v", 1, "local", "continuous", None),
    (30, "switch.R1.i", 6, "local", "continuous", None), (31, "switch.R2.v", 1, "local", "continuous", None),
    (32, "switch.R2.i", 6, "local", "continuous", None), (33, "switch.v", 1, "local", "continuous", None),
    (34, "switch.node.v", 7, "local", "continuous", None), (35, "switch.R", 1, "local", "continuous", None),
    (36, "ambient.port.T", 2, "local", "continuous", None), (37, "wall.dT", 1, "local", "continuous", None),
    (38, "wall.Q", 5, "local", "continuous", None), (39, "heater.v", 1, "local", "continuous", None),
    (40, "heater.i", 6, "local", "continuous", None), (41, "heater.Q_joule", 2, "local", "continuous", None),
    (42, "heater.R", 1, "local", "continuous", None), (43, "supply.v", 1, "local", "continuous", None),
    (44, "switch.top.v", 7, "local", "continuous", None), (45, "heater.Q_net", 2, "local", "continuous", None),
    (46, "T_reference", 1, "output", "continuous", None), (47, "T_room", 1, "output", "continuous", None),
    (48, "switch.i", 5, "local", "continuous", None), (49, "heater.Q_int", 1, "local", "continuous", None),
    (50, "heater.dQ", 1, "local", "continuous", None),
]
BOOLEANS_20SIM = [(23, "controller.state"), (24, "controller.next_state")]

# workload: (C source, model identifier, description)
WORKLOADS = {"harsh": ("controlled_temperature.c", "ControlledTemperature",
                       "a heated rod under PI control: the recording benchmark's stand-in for 20-sim's"
                       " ControlledTemperature (every value changes in every step)"),
             "20sim": ("controlled_temperature_20sim.c", "ControlledTemperature20sim",
                       "a heater switched around a ramped set-point: the recording benchmark's stand-in with the"
                       " variable make-up of 20-sim's ControlledTemperature (aliases, parameters, Booleans)")}


def variables_20sim() -> list[tuple]:
    """(name, value reference, type, causality, variability, initial, start): every alias a variable of its own."""
    out = []
    for vr, name, count, caus, var, start in LAYOUT_20SIM:
        init = "exact" if caus == "parameter" else "calculated"
        out += [(name if k == 0 else f"{name}.alias{k}", vr, "Real", caus, var, init, start) for k in range(count)]
    out += [(name, vr, "Boolean", "local", "discrete", "calculated", None) for vr, name in BOOLEANS_20SIM]
    return out


def _variables(workload: str) -> list[tuple]:
    if workload == "20sim":
        return variables_20sim()
    return [(name, vr, "Real", caus, var, init, start) for vr, (name, caus, var, init, start) in enumerate(variables())]


def _model_description(guid: str, workload: str = "harsh") -> str:
    vs = _variables(workload)
    _, ident, description = WORKLOADS[workload]
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName="{ident}" guid="{guid}"'
             f' description="{description}" generationTool="cosim-master bench/recording/build.py"'
             ' variableNamingConvention="structured" numberOfEventIndicators="0">',
             f'  <CoSimulation modelIdentifier="{ident}" canHandleVariableCommunicationStepSize="true"'
             ' canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="false" canSerializeFMUstate="false"'
             ' canInterpolateInputs="false" maxOutputDerivativeOrder="0"/>',
             '  <DefaultExperiment startTime="0" stopTime="20" stepSize="0.0001"/>',
             "  <ModelVariables>"]
    for name, vr, typ, caus, var, init, start in vs:
        value = f'<{typ} start="{start!r}"/>' if start is not None else f"<{typ}/>"
        lines += [f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="{caus}" variability="{var}"'
                  f' initial="{init}">', f"      {value}", "    </ScalarVariable>"]
    outputs = [k + 1 for k, v in enumerate(vs) if v[3] == "output"]
    unknowns = "".join(f'<Unknown index="{k}" dependencies=""/>' for k in outputs)
    lines += ["  </ModelVariables>", "  <ModelStructure>", f"    <Outputs>{unknowns}</Outputs>",
              f"    <InitialUnknowns>{unknowns}</InitialUnknowns>", "  </ModelStructure>",
              "</fmiModelDescription>", ""]
    return "\n".join(lines)


def build_fmu(out_dir, workload: str = "harsh") -> Path:
    """The FMU of ``workload`` ("harsh" or "20sim", see above) in ``out_dir``, rebuilt on every call (it takes a
    second)."""
    if sys.platform != "linux":
        raise RuntimeError("the benchmark's C FMU is built for Linux x86_64 only")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    source, ident, _ = WORKLOADS[workload]
    src = HERE / source
    common = HERE.parent / "fmi2_stubs" / "fmi2_common.h"
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master-bench-recording/" + src.read_text()
                                + common.read_text())) + "}"
    with tempfile.TemporaryDirectory(prefix="recording_fmu_") as tmp:
        root = Path(tmp) / "fmu"
        bindir = root / "binaries" / "linux64"
        bindir.mkdir(parents=True)
        (root / "sources").mkdir()
        cmd = [os.environ.get("CC", "cc"), "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Wextra",
               "-ffp-contract=off", f"-I{fmi_headers_dir()}", f"-I{common.parent}", str(src), "-lm", "-o", str(bindir / f"{ident}.so")]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"the C compiler failed:\n{' '.join(cmd)}\n{proc.stderr}")
        for f in (src, common):
            shutil.copy2(f, root / "sources" / f.name)
        (root / "modelDescription.xml").write_text(_model_description(guid, workload), encoding="utf-8")
        fmu = out_dir / f"{ident}.fmu"
        _zip_dir(root, fmu)
    return fmu


if __name__ == "__main__":
    print(build_fmu(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="recording_"),
                    sys.argv[2] if len(sys.argv) > 2 else "harsh"))
