"""The output dependencies the shipped UAV FMUs declare (FMI 2.0 ModelStructure) are the models' own.

An output that declares no dependency on an input must not change when that input alone is set (direct
feedthrough is the only way an input reaches an output without a doStep).  For every input of every shipped
FMU the test sets a different value and reads every output again, in Initialization Mode (against
``InitialUnknowns``) and during a mission-like run (against ``Outputs``), and compares what changed with what
the model description declares.  The check is shown to see feedthrough where there is some: the coupling
benchmark's PyMassB (F = kc (x - x_in), declared) passes it only because its declaration names x_in.

Before the declarations (pythonfmu writes none) every output depended on every input in FMI's reading, and
OMSimulator, which orders and solves by them, found an algebraic loop through the Integer ``phase`` and
refused every UAV SSP ("[getReal] Unknown signal").
"""
from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from pythonfmu import Fmi2Slave

# imported before any FMU of this module runs in the process (a pythonfmu FMU puts its resources, with their own
# copy of uavsim, first on sys.path)
from uavsim.fmi import UnitsMixin

REPO = Path(__file__).resolve().parents[3]
FMUS = REPO / "fmus"
STEP = 0.1

#: per FMU: parameters set before initialisation, and the inputs held while stepping into a state in which an
#: output could react to an input (flying, motors on, mission under way)
SCENES = {
    "UavDynamics": ({}, {"cmd": 1, "sp_z": 20.0, "wind_x": 2.0}, 120),
    "UavBattery": ({}, {"phase": 2, "airspeed": 8.0, "vz": 0.5}, 50),
    "UavWind": ({"probability": 1.0, "seed": 3}, {}, 50),
    "UavStrategy": ({"n_targets": 2, "target_x_1": 30.0, "target_y_1": 0.0, "target_x_2": 0.0, "target_y_2": 40.0,
                     "n_zones": 0},
                    {"phase": 2, "z": 20.0, "x": 5.0, "y": 1.0, "consumed": 0.1}, 30),
}


def _variables(md, causality):
    return [v for v in md.modelVariables if v.causality == causality]


def _declared(md, section) -> dict[str, set[str]]:
    """output name -> names of the inputs it depends on, as the model description declares (None: all)."""
    inputs = {v.name for v in _variables(md, "input")}
    unknowns = md.outputs if section == "Outputs" else md.initialUnknowns
    out = {}
    for u in unknowns:
        if u.variable.causality != "output":
            continue
        deps = u.dependencies
        out[u.variable.name] = inputs if deps is None else {d.name for d in deps} & inputs
    return out


class _Probe:
    def __init__(self, fmu: Path, tmp: Path):
        self.md = read_model_description(str(fmu))
        self.dir = extract(str(fmu), unzipdir=str(tmp / fmu.stem))
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=fmu.stem)
        self.by_name = {v.name: v for v in self.md.modelVariables}
        self.outputs = _variables(self.md, "output")
        self.inputs = _variables(self.md, "input")

    def set(self, name, value):
        v = self.by_name[name]
        if v.type == "Real":
            self.slave.setReal([v.valueReference], [float(value)])
        elif v.type in ("Integer", "Enumeration"):
            self.slave.setInteger([v.valueReference], [int(value)])
        elif v.type == "Boolean":
            self.slave.setBoolean([v.valueReference], [bool(value)])

    def get(self, v):
        if v.type == "Real":
            return self.slave.getReal([v.valueReference])[0]
        if v.type == "Boolean":
            return self.slave.getBoolean([v.valueReference])[0]
        return self.slave.getInteger([v.valueReference])[0]

    def outputs_now(self) -> dict:
        return {v.name: self.get(v) for v in self.outputs}

    def feedthrough(self) -> dict[str, set[str]]:
        """output -> the inputs whose change alone changed it (each input moved away and back)."""
        seen = {v.name: set() for v in self.outputs}
        for i in self.inputs:
            before, old = self.outputs_now(), self.get(i)
            self.set(i.name, old + (7 if i.type != "Real" else 13.25))
            after = self.outputs_now()
            self.set(i.name, old)
            for name in seen:
                if after[name] != before[name]:
                    seen[name].add(i.name)
        return seen


def _observed_within_declared(observed, declared):
    extra = {o: sorted(ins - declared[o]) for o, ins in observed.items() if ins - declared[o]}
    assert not extra, f"outputs that change with inputs they do not declare: {extra}"


@pytest.mark.parametrize("name", ["UavDynamics", "UavBattery", "UavWind", "UavStrategy", "UavSitl"])
def test_shipped_fmus_declare_dependencies_for_every_output(name):
    md = read_model_description(str(FMUS / f"{name}.fmu"))
    outputs = {v.name for v in _variables(md, "output")}
    for section in ("Outputs", "InitialUnknowns"):
        unknowns = md.outputs if section == "Outputs" else md.initialUnknowns
        declared = {u.variable.name for u in unknowns if u.dependencies is not None}
        assert declared >= outputs, f"{name} {section}: no dependencies on {sorted(outputs - declared)}"


def probe(fmu: str, tmp: str, params: dict, held: dict, steps: int, run: bool = True) -> dict:
    """What changed with which input (Initialization Mode, then after ``steps`` steps with ``held``), what the model
    description declares, and whether stepping moved an output."""
    p = _Probe(Path(fmu), Path(tmp))
    s = p.slave
    s.instantiate()
    report = {}
    try:
        s.setupExperiment(startTime=0.0)
        for k, v in params.items():
            p.set(k, v)
        s.enterInitializationMode()
        report["init"] = (p.feedthrough(), _declared(p.md, "InitialUnknowns"))
        if run:
            s.exitInitializationMode()
            for k, v in held.items():
                p.set(k, v)
            start = p.outputs_now()
            for n in range(steps):
                s.doStep(currentCommunicationPoint=n * STEP, communicationStepSize=STEP)
            report["live"] = p.outputs_now() != start
            report["run"] = (p.feedthrough(), _declared(p.md, "Outputs"))
            s.terminate()
    finally:
        s.freeInstance()
        shutil.rmtree(p.dir, ignore_errors=True)
    return {k: [{o: sorted(i) for o, i in d.items()} for d in v] if isinstance(v, tuple) else v
            for k, v in report.items()}


# The child leaves with os._exit once its answer is out: pythonfmu's binary, loaded into a Python process, leaves
# objects behind after fmi2FreeInstance whose release during interpreter shutdown aborted the child now and then
# ("corrupted double-linked list", 2 runs of the suite in 3) after it had printed a correct report.
_CHILD = r"""
import importlib.util, json, os, sys
spec = importlib.util.spec_from_file_location("probe_module", sys.argv[1])
module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
print(json.dumps(module.probe(*json.loads(sys.argv[2]))), flush=True)
os._exit(0)
"""


def _probe_in_child(*args) -> dict:
    """``probe`` in a child process: a pythonfmu FMU run here would put its resources (a copy of uavsim, deleted
    afterwards) first on sys.path and into sys.modules, where later tests in this process would find it."""
    import program_server           # here: the child loads this file, without the tests' folder on its path
    proc = program_server.run([sys.executable, "-c", _CHILD, __file__,
                               json.dumps([str(a) if isinstance(a, Path) else a for a in args])],
                              capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    return {k: [{o: set(i) for o, i in d.items()} for d in v] if isinstance(v, list) else v for k, v in report.items()}


@pytest.mark.parametrize("name", list(SCENES))
def test_declared_dependencies_are_the_models(name, tmp_path):
    params, held, steps = SCENES[name]
    report = _probe_in_child(FMUS / f"{name}.fmu", tmp_path, params, held, steps)
    _observed_within_declared(*report["init"])
    # the scene is live: stepping moved some output (else no input could have shown through)
    assert report["live"]
    _observed_within_declared(*report["run"])


def test_sitl_fmu_has_no_feedthrough_in_initialization_mode(tmp_path):
    """UavSitl starts ArduPilot only in exitInitializationMode; before that its declaration is checked the
    same way (the run-time outputs are the vehicle's telemetry, read back in doStep)."""
    report = _probe_in_child(FMUS / "UavSitl.fmu", tmp_path, {}, {}, 0, False)
    _observed_within_declared(*report["init"])


def test_the_probe_sees_feedthrough_where_there_is_some(tmp_path):
    """PyMassB's coupling force F = kc (x - x_in) is direct feedthrough from x_in: the probe finds exactly
    that, so an undeclared one in the UAV FMUs would not go unseen."""
    report = _probe_in_child(REPO / "ssp" / "coupling" / "fmus" / "PyMassB.fmu", tmp_path, {}, {}, 1)
    observed, declared = report["run"]
    assert observed == {"x": set(), "v": set(), "F": {"x_in"}}
    assert declared == observed


def test_a_declaration_naming_no_output_or_no_input_stops_the_build():
    def shell(deps):
        class Shell(UnitsMixin, Fmi2Slave):
            output_dependencies = deps

            def __init__(self, **kw):
                super().__init__(**kw)
                self.u, self.y = 0.0, 0.0
                self.in_real("u", "m", "input")
                self.out_real("y", "m", "output")

            def do_step(self, t, h):
                return True
        return Shell(instance_name="s", resources=None)

    root = shell({"y": ["u"]}).to_xml()
    assert [u.get("dependencies") for u in root.find("ModelStructure/Outputs")] == ["1"]
    with pytest.raises(ValueError, match="'u' is no output"):
        shell({"u": []}).to_xml()
    with pytest.raises(ValueError, match="'y' is no input"):
        shell({"y": ["y"]}).to_xml()
