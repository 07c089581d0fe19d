"""The UavBattery FMU (pythonfmu over uavsim/battery.py) swapped for a native C twin.

``tests/fmu_sources/uavsim/c_battery/UavBatteryC.c`` implements the FMI 2.0 Co-Simulation API and the battery model
of ``fmu_sources/uavsim/battery.py`` (Zeng rotary-wing power, climb power, coulomb counting on
sub-steps, OCV table interpolation, internal resistance, current from power and terminal voltage)
in plain C.  The test generates its modelDescription.xml and a C header with the value references
from the Python FMU's own modelDescription.xml, so the connectors are the same by construction
(start values: the Python slave's exact defaults, see ``_DEFAULTS_SCRIPT``), compiles it with gcc
into tmp, and checks:

* the C FMU is native (generationTool, no Python in the archive or in the shared library);
* FMU level: the C FMU and ``uavsim.battery.Battery`` give the same outputs for varied inputs,
  parameters and step sizes (every branch: ground/motors, climb/descent, overload, depletion,
  sub-steps that do not divide the step);
* mission level: a 4-UAV mission SSP built by ``uavstudy.build``, run once as built and once with
  every ``uavN_bat`` component pointing at the C FMU, gives the same summary.json (outcomes, targets,
  photos, distances, flight times, energy, remaining battery) and the same battery time series.

Tolerances: mission level 1e-6 relative (REL) for the continuous quantities, exact for the discrete
ones; FMU level 1e-12 relative (STEP_REL: a handful of steps, so a different libm could only add a few
ulps; tight enough to see a wrong sub-step count, a 1.7e-7 effect the mission tolerance would not see).
The C code performs the same IEEE-754 double operations in the same order as the Python code (CPython
evaluates left to right, its ``**`` calls the C library's ``pow``, ``math.sqrt`` is the correctly
rounded square root), it is compiled with ``-ffp-contract=off`` (no fused multiply-add) and
``-fno-builtin`` (``pow(x, 2.0)`` is called, not turned into ``x*x``), and on x86-64 there is no
x87 excess precision; on the same libm the results are therefore bit-identical (measured: 0).  The
tolerance leaves room for a different libm (``pow`` correct to < 1 ulp but not always correctly
rounded) or compiler, which would give ulp-level differences per operation that accumulate over
the ~10^4 coulomb-counting sub-steps to ~1e-12 relative, and it is still far below the effect of a
modelling difference such as a missing climb term (~1e-2 in energy).
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import uuid
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from lxml import etree

import master
import program_server
from fmu_factory import fmi_headers_dir
from uavstudy.build import build_scenario, default_fmu_dir
from uavsim import params as P
from uavsim.battery import Battery, BatteryParams, PowerParams
from uav_places import BASE, latlon

HERE = Path(__file__).resolve().parent
C_SOURCE = HERE / "c_battery" / "UavBatteryC.c"
PY_FMU = default_fmu_dir() / "UavBattery.fmu"
MODEL = "UavBatteryC"
GENERATION_TOOL = "cosim-master tests/fmu_sources/uavsim/test_battery_swap_c.py (native C, gcc)"
REL = 1e-6          # relative tolerance of the continuous results (see the module docstring)
STEP_REL = 1e-12    # FMU level (a few steps, < 100 sub-steps each): a different libm/compiler stays below ~1e-14
ATOL_POS = 1e-9     # m, for final positions near 0

pytestmark = [
    pytest.mark.skipif(not PY_FMU.is_file(), reason="UAV FMUs not built (python fmu_sources/build_fmus.py)"),
    pytest.mark.skipif(shutil.which(os.environ.get("CC", "gcc")) is None, reason="no C compiler"),
]


# ------------------------------------------------------------------------------------------ build
# The Python FMU's effective defaults: its own (bundled) shell class instantiated in a child process (no
# import side effects here).  pythonfmu 0.7 writes Real start values with 16 significant digits
# (f"{value:.16g}"), which is not always the double the slave uses: UavBattery's solidity
# 0.10025508226261125 is written as 0.1002550822626112.  The C twin takes the slave's exact values.
_DEFAULTS_SCRIPT = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import pythonfmu  # noqa: F401  (the installed package first)
module = __import__(open(sys.argv[1] + "/slavemodule.txt").read().split()[0])
slave = getattr(module, sys.argv[2])(instance_name="defaults")
print(json.dumps({v.name: repr(getattr(slave, v.name)) for v in slave.vars.values()}))
"""


def _python_defaults(tmp: Path) -> dict[str, str]:
    with zipfile.ZipFile(PY_FMU) as z:
        z.extractall(tmp / "py_fmu")
    proc = program_server.run([sys.executable, "-c", _DEFAULTS_SCRIPT, str(tmp / "py_fmu" / "resources"),
                               "UavBattery"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def _c_model_description(py_md: bytes, guid: str, defaults: dict[str, str]) -> bytes:
    """The Python FMU's modelDescription with only the identity changed (same variables, units, structure) and
    the start values written exactly (round-trip repr) from the slave's own defaults."""
    root = etree.fromstring(py_md)
    for sv in root.find("ModelVariables").findall("ScalarVariable"):
        t = sv[0]
        if t.get("start") is not None:
            exact = defaults[sv.get("name")]
            assert f"{float(exact):.16g}" == t.get("start") or float(exact) == float(t.get("start"))
            t.set("start", exact)
    root.set("modelName", MODEL)
    root.set("guid", guid)
    root.set("generationTool", GENERATION_TOOL)
    root.attrib.pop("generationDateAndTime", None)
    root.set("description", root.get("description", "") + " -- native C twin (test)")
    cs = root.find("CoSimulation")
    cs.set("modelIdentifier", MODEL)
    cs.set("needsExecutionTool", "false")
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8")


def _c_doubles(values) -> str:
    return ", ".join(repr(float(v)) for v in values)


def _vars_header(md: bytes, guid: str) -> str:
    """UavBatteryC_vars.h from the modelDescription: value references, types, kinds, start values."""
    root = etree.fromstring(md)
    svs = root.find("ModelVariables").findall("ScalarVariable")
    vrs = [int(v.get("valueReference")) for v in svs]
    assert sorted(vrs) == list(range(len(vrs))), "the C twin expects value references 0..N-1"
    n = len(svs)
    types, kinds = ["?"] * n, ["?"] * n
    start_r, start_i = ["0.0"] * n, ["0"] * n
    lines = ["/* generated by tests/fmu_sources/uavsim/test_battery_swap_c.py from UavBattery.fmu's modelDescription.xml */",
             "#ifndef UAVBATTERYC_VARS_H", "#define UAVBATTERYC_VARS_H",
             f'#define MODEL_GUID "{guid}"', f"#define N_VARS {n}"]
    for sv, vr in zip(svs, vrs):
        t = sv[0]
        types[vr] = {"Real": "R", "Integer": "I"}[t.tag]        # the battery has no Boolean/String
        kinds[vr] = {"parameter": "p", "input": "i", "output": "o"}[sv.get("causality")]
        if t.get("start") is not None:
            if t.tag == "Real":
                start_r[vr] = repr(float(t.get("start")))
            else:
                start_i[vr] = str(int(t.get("start")))
        lines.append(f"#define VR_{sv.get('name')} {vr}")
    lines += [f'static const char VAR_TYPE[] = "{"".join(types)}";',
              f'static const char VAR_KIND[] = "{"".join(kinds)}";',
              f"static const double START_REAL[N_VARS] = {{{', '.join(start_r)}}};",
              f"static const int START_INT[N_VARS] = {{{', '.join(start_i)}}};",
              f"#define UAV_G0 {P.G0!r}",
              f"#define OCV_N {len(P.OCV_SOC)}",
              f"static const double OCV_SOC[OCV_N] = {{{_c_doubles(P.OCV_SOC)}}};",
              f"static const double OCV_CELL[OCV_N] = {{{_c_doubles(P.OCV_CELL)}}};",
              "#endif", ""]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def c_fmu(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("c_battery")
    with zipfile.ZipFile(PY_FMU) as z:
        py_md = z.read("modelDescription.xml")
    src = C_SOURCE.read_bytes()
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "cosim-master/UavBatteryC/"
                                + hashlib.sha256(src + py_md).hexdigest())) + "}"
    md = _c_model_description(py_md, guid, _python_defaults(tmp))
    root = tmp / "fmu"
    (root / "binaries" / "linux64").mkdir(parents=True)
    (root / "sources").mkdir()
    (root / "modelDescription.xml").write_bytes(md)
    (root / "sources" / "UavBatteryC_vars.h").write_text(_vars_header(md, guid))
    shutil.copy2(C_SOURCE, root / "sources" / C_SOURCE.name)
    cmd = [os.environ.get("CC", "gcc"), "-shared", "-fPIC", "-O2", "-std=gnu11", "-Wall", "-Wextra", "-Werror",
           "-ffp-contract=off", "-fno-builtin", f"-I{fmi_headers_dir()}", f"-I{root / 'sources'}",
           str(root / "sources" / C_SOURCE.name), "-o", str(root / "binaries" / "linux64" / f"{MODEL}.so"), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, f"gcc failed:\n{proc.stderr}"
    fmu = tmp / f"{MODEL}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in sorted(root.rglob("*")):
            if f.is_file():
                zf.write(f, f.relative_to(root).as_posix())
    return fmu


# ------------------------------------------------------------------------------------------ native, same connectors
def test_c_battery_is_native_with_the_same_connectors(c_fmu, tmp_path):
    from fmpy import read_model_description

    py, c = read_model_description(str(PY_FMU)), read_model_description(str(c_fmu))

    def sig(md):
        return [(v.name, v.valueReference, v.type, v.causality, v.variability, v.initial,
                 getattr(v, "unit", None), v.description) for v in md.modelVariables]

    assert sig(c) == sig(py)
    # start values: the same, except that pythonfmu 0.7 rounds Real starts to 16 digits (see _DEFAULTS_SCRIPT)
    for vp, vc in zip(py.modelVariables, c.modelVariables):
        if vp.type == "Real" and vp.start is not None:
            assert f"{float(vc.start):.16g}" == f"{float(vp.start):.16g}"
            assert math.isclose(float(vc.start), float(vp.start), rel_tol=1e-15), vp.name
        else:
            assert vc.start == vp.start, vp.name
    assert [(u.variable.name, [d.name for d in (u.dependencies or [])]) for u in c.outputs] == \
           [(u.variable.name, [d.name for d in (u.dependencies or [])]) for u in py.outputs]
    xml = {}
    for key, path in (("py", PY_FMU), ("c", c_fmu)):
        with zipfile.ZipFile(path) as z:
            root = etree.fromstring(z.read("modelDescription.xml"))
        xml[key] = [etree.tostring(root.find(tag), method="c14n") for tag in ("UnitDefinitions", "ModelStructure")]
    assert xml["c"] == xml["py"]
    # every variable of the Python FMU is used by the C source (a new one would need C code)
    text = C_SOURCE.read_text()
    assert [v.name for v in py.modelVariables if f"VR_{v.name}" not in text] == []

    # native: generated by us, no pythonfmu resources, a shared library without Python
    assert py.generationTool.startswith("PythonFMU") and c.generationTool == GENERATION_TOOL
    assert c.coSimulation.modelIdentifier == MODEL and not c.coSimulation.needsExecutionTool
    with zipfile.ZipFile(c_fmu) as z:
        names = z.namelist()
        so_bytes = z.read(f"binaries/linux64/{MODEL}.so")
    assert not [n for n in names if n.startswith("resources/") or n.endswith(".py")]
    assert sorted(names) == sorted(["modelDescription.xml", f"binaries/linux64/{MODEL}.so",
                                    f"sources/{MODEL}.c", f"sources/{MODEL}_vars.h"])
    so = tmp_path / f"{MODEL}.so"
    so.write_bytes(so_bytes)
    needed = [line.split("[", 1)[1].rstrip("]") for line in
              subprocess.run(["readelf", "-d", str(so)], capture_output=True, text=True, check=True).stdout.splitlines()
              if "(NEEDED)" in line]
    assert set(needed) <= {"libm.so.6", "libc.so.6"}, needed
    undefined = subprocess.run(["nm", "-D", "--undefined-only", str(so)], capture_output=True, text=True,
                               check=True).stdout.split()
    assert not [s for s in undefined if s.startswith("Py") or "python" in s.lower()]
    assert b"python" not in so_bytes.lower()
    exported = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True,
                              check=True).stdout
    for fn in ("fmi2Instantiate", "fmi2DoStep", "fmi2GetReal", "fmi2SetInteger", "fmi2ExitInitializationMode"):
        assert f" {fn}\n" in exported


# ------------------------------------------------------------------------------------------ FMU level
CASES = [  # parameters, list of (dt, airspeed, vz, phase)
    ({}, [(0.5, 0.0, 0.0, 0), (0.5, 0.0, 2.5, 1), (1.0, 0.0, 2.5, 1), (0.05, 7.5, 0.0, 2), (0.1, 10.0, 0.0, 2),
          (0.5, 16.0, -1.5, 2), (0.5, 3.0, -0.5, 3), (0.5, 0.0, 0.0, 4), (0.0, 5.0, 0.0, 2), (2.0, 12.0, 1.0, 2)]),
    ({"initial_soc": 0.03, "cells": 4}, [(1.0, 0.0, 2.5, 1)] * 40 + [(0.5, 0.0, 0.0, 4)] * 4),  # depletes: soc 0
    ({"cell_resistance": 0.1, "rotor_count": 6, "substep": 0.03},      # overload; 0.03 s does not divide 0.5 s
     [(0.5, 0.0, 0.0, 0), (0.5, 0.0, 2.5, 1), (0.5, 10.0, 0.0, 2), (0.37, 4.0, 0.3, 2), (0.5, 0.0, -0.5, 3)]),
    ({"mass": 2.1, "rho": 1.1, "efficiency": 0.7, "avionics_power": 9.0, "capacity_ah": 2.2, "initial_soc": 0.61,
      "cell_resistance": 0.0, "tip_speed": 120.0, "solidity": 0.08},   # R = 0: I = P / E
     [(0.25, 8.0, 0.5, 2)] * 20),
]

OUTPUTS = ("soc", "consumed", "voltage", "current", "power", "energy_used", "depleted")


def _python_reference(params, steps):
    pk = {k: v for k, v in params.items() if k in PowerParams.__dataclass_fields__}
    bk = {k: v for k, v in params.items() if k in BatteryParams.__dataclass_fields__}
    m = Battery(PowerParams(**pk), BatteryParams(**bk))
    rows = []
    for dt, v, vz, ph in steps:
        m.step(dt, v, vz, ph)
        rows.append((m.soc, m.consumed, m.voltage, m.current, m.power, m.energy_used, int(m.depleted)))
    return rows


def _c_run(fmu, params, steps, unzip_dir):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), unzipdir=str(unzip_dir)), modelIdentifier=MODEL,
                  instanceName="bat")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for k, val in params.items():
        (s.setInteger if isinstance(val, int) else s.setReal)([vr[k]], [val])
    s.exitInitializationMode()
    rows, t = [], 0.0
    real_vrs = [vr[k] for k in OUTPUTS[:-1]]
    for dt, v, vz, ph in steps:
        s.setReal([vr["airspeed"], vr["vz"]], [v, vz])
        s.setInteger([vr["phase"]], [ph])
        s.doStep(t, dt)
        t += dt
        rows.append(tuple(s.getReal(real_vrs)) + tuple(s.getInteger([vr["depleted"]])))
    s.terminate()
    s.freeInstance()
    return rows


@pytest.mark.parametrize("case", range(len(CASES)))
def test_c_battery_steps_like_the_python_model(c_fmu, case, record_property, tmp_path):
    params, steps = CASES[case]
    ref = np.array(_python_reference(params, steps))
    got = np.array(_c_run(c_fmu, params, steps, tmp_path / "fmu"))
    np.testing.assert_allclose(got, ref, rtol=STEP_REL, atol=0)
    record_property("max_rel_diff", _max_rel(ref, got))      # measured: 0 (bit-identical on the same libm)
    if case == 1:
        assert ref[-1, 0] == 0.0 and ref[-1, 6] == 1          # depleted, soc clamped, OCV below the table
    if case == 2:
        assert abs(ref[2, 4] - ref[2, 2] ** 2 / 0.3) < 1e-9  # overload: U = E/2, P = E^2/4R = U^2/R


# ------------------------------------------------------------------------------------------ mission level
# UAV i gets targets 2i, 2i+1 (equal assignment), near its pad on the 5.66 m ring
TARGETS_ENU = [(-15, 45), (15, 45), (45, 15), (45, -15), (15, -45), (-15, -45), (-45, -15), (-45, 15)]
#: the same parameter overrides for both runs: every branch of the battery in one mission
MISSION_PARAMS = {
    "uav2_bat.initial_soc": 0.215,            # crosses the 80 % return threshold on its first leg
    "uav3_bat.initial_soc": 0.003, "uav3_bat.cells": 4,  # >= 95 % consumed at once: lands on its pad and
                                              # depletes (soc 0, OCV below the table)
    "uav4_bat.cell_resistance": 0.1, "uav4_bat.rotor_count": 6,   # overload (E^2 < 4 R P) ...
    "uav4_bat.substep": 0.03,                 # ... sub-steps that do not divide the 0.5 s step ...
    "uav4_bat.initial_soc": 0.12, "uav4_strat.return_threshold": 0.99,   # ... and a forced landing away
    "uav4_strat.land_threshold": 0.9,         # from its pad during the first leg
}
BAT_OUTPUTS = ("soc", "consumed", "voltage", "current", "power", "energy_used")
EXACT_KEYS = ("uav", "index", "outcome", "success", "targets_assigned", "targets_visited", "visited_targets",
              "assigned_targets", "photos", "final_phase", "final_mission_state", "returned_low_battery",
              "forced_landing", "removed_time", "removed_by", "mission_states")
FLOAT_KEYS = ("distance_m", "distance_xy_m", "flight_time_s", "energy_used_J", "energy_used_Wh",
              "remaining_battery_pct", "consumed_pct", "final_x", "final_y", "final_z", "distance_to_home_m")


def _swap_battery(ssp: Path, c_fmu: Path, out: Path) -> Path:
    """Copy of the SSP with every uavN_bat component's source pointing at the C FMU."""
    with zipfile.ZipFile(ssp) as zin:
        ssd = etree.fromstring(zin.read("SystemStructure.ssd"))
        swapped = 0
        for comp in ssd.iter("{*}Component"):
            if comp.get("name").endswith("_bat"):
                assert comp.get("source") == "resources/UavBattery.fmu"
                comp.set("source", f"resources/{c_fmu.name}")
                swapped += 1
        assert swapped == 4
        with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as zout:
            for item in zin.infolist():
                if item.filename == "SystemStructure.ssd":
                    zout.writestr(item, etree.tostring(ssd, xml_declaration=True, encoding="UTF-8"))
                elif item.filename != "resources/UavBattery.fmu":      # no longer referenced
                    zout.writestr(item, zin.read(item))
            zout.write(c_fmu, f"resources/{c_fmu.name}")
    return out


@pytest.fixture(scope="module")
def mission_ssp(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("swap_mission")

    scenario = {"name": "battery_swap", "base": {"lat": BASE[0], "lon": BASE[1], "alt": BASE[2]}, "n_uavs": 4,
                "strategy": "B", "assignment": "equal", "targets": [latlon(e, n) for e, n in TARGETS_ENU],
                "wind": {"probability": 0.3, "decision_interval": 5.0}, "seed": 3, "step": 0.5, "stop_time": 110.0,
                "end_when_all_landed": False}     # the step-by-step comparison runs to the stop time
    y = tmp / "battery_swap.yaml"
    y.write_text(yaml.safe_dump(scenario, sort_keys=False))
    return build_scenario(y, tmp / "battery_swap.ssp")


def _max_rel(a, b) -> float:
    a, b = np.ravel(np.asarray(a, float)), np.ravel(np.asarray(b, float))
    d = np.abs(a - b)
    nz = d != 0
    return float(np.max(d[nz] / np.maximum(np.abs(a[nz]), np.abs(b[nz])))) if nz.any() else 0.0


def test_mission_summary_same_with_c_battery(mission_ssp, c_fmu, tmp_path, record_property):
    c_ssp = _swap_battery(mission_ssp, c_fmu, tmp_path / "battery_swap_c.ssp")
    rec = [f"uav*_bat.{v}" for v in BAT_OUTPUTS] + ["uav*_dyn.x", "uav*_dyn.y", "uav*_dyn.z"]
    r_py = master.run(mission_ssp, output=tmp_path / "py", params=MISSION_PARAMS, record=rec, record_interval=0.5)
    r_c = master.run(c_ssp, output=tmp_path / "c", params=MISSION_PARAMS, record=rec, record_interval=0.5)
    assert r_py.ok and r_c.ok

    # the second run really used the native FMU for every battery, the first the pythonfmu one
    for i in range(1, 5):
        assert r_py.metadata["fmus"][f"uav{i}_bat"]["generation_tool"].startswith("PythonFMU")
        c_info = r_c.metadata["fmus"][f"uav{i}_bat"]
        assert c_info["generation_tool"] == GENERATION_TOOL and c_info["source"] == f"resources/{c_fmu.name}"
        assert r_c.metadata["fmus"][f"uav{i}_dyn"]["generation_tool"].startswith("PythonFMU")

    s_py = json.loads((r_py.output_dir / "summary.json").read_text())
    s_c = json.loads((r_c.output_dir / "summary.json").read_text())
    worst = {}
    for u_py, u_c in zip(s_py["uavs"], s_c["uavs"], strict=True):
        assert {k: u_py[k] for k in EXACT_KEYS} == {k: u_c[k] for k in EXACT_KEYS}
        for k in FLOAT_KEYS:
            a, b = u_py[k], u_c[k]
            assert math.isclose(a, b, rel_tol=REL, abs_tol=ATOL_POS), (u_py["uav"], k, a, b)
            worst[k] = max(worst.get(k, 0.0), _max_rel(a, b))
    tot_py, tot_c = s_py["total"], s_c["total"]
    assert tot_py.keys() == tot_c.keys()
    for k, a in tot_py.items():
        b = tot_c[k]
        if isinstance(a, float) and isinstance(b, float):
            assert math.isclose(a, b, rel_tol=REL, abs_tol=ATOL_POS), (k, a, b)
        else:
            assert a == b, k

    # the mission exercised the battery: a success, a low-battery return, an at-once landing that depletes
    # the pack, a forced landing away from the pad (overloaded pack)
    u1, u2, u3, u4 = s_py["uavs"]
    assert u1["outcome"] == "success" and u1["targets_visited"] == 2
    assert u2["outcome"] == "battery_return" and u2["returned_low_battery"]
    assert u3["mission_states"] == ["landing", "landed_base"] and u3["remaining_battery_pct"] == 0.0
    assert u4["outcome"] == "forced_landing" and u4["mission_states"][-1] == "landed_away"

    # every recorded battery output and the trajectory at every step
    f_py, f_c = r_py.frame, r_c.frame
    assert list(f_py.columns) == list(f_c.columns) and len(f_py) == len(f_c) == 221
    for col in f_py.columns:
        np.testing.assert_allclose(f_c[col], f_py[col], rtol=REL, atol=ATOL_POS, err_msg=col)
        worst[col] = _max_rel(f_py[col], f_c[col])
    # measured: 0 everywhere (bit-identical on the same libm, see the module docstring)
    record_property("max_rel_diff", max(worst.values()))
