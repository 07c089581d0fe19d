"""FMI conformance beyond what fmpy checks, against expectations derived independently of the master: the
Modelica Reference FMUs' own results (``ref/*.csv``), hand computations, and the call sequences the FMI
standard allows (our C framework logs "illegal call sequence" for any other)."""
import json
import logging
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from lxml import etree

import master
from cli_in_process import run_cli
from master.errors import FmuError, ScenarioError
from master.manipulators import Manipulator
from master.ssp.writer import SspBuilder

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"


def _reference(reference_fmus, model: str, suffix: str = "out") -> pd.DataFrame:
    return pd.read_csv(reference_fmus / "ref" / f"{model}_{suffix}.csv")


def _run(ssp, out, **options):
    master.run(ssp, output=out, record=["*"], **options)
    return json.loads((out / "run.json").read_text()), pd.read_csv(out / "results.csv")


def _edit_xml_in_zip(src: Path, member: str, edit, dst: Path | None = None) -> Path:
    """A copy of the archive (``dst``, default: in place) with ``edit(root)`` applied to one XML member."""
    with zipfile.ZipFile(src) as zf:
        items = {name: zf.read(name) for name in zf.namelist()}
    root = etree.fromstring(items[member])
    edit(root)
    items[member] = etree.tostring(root, xml_declaration=True, encoding="UTF-8")
    with zipfile.ZipFile(dst or src, "w") as zf:
        for name, data in items.items():
            zf.writestr(name, data)
    return dst or src


def _with_implementation(ssp: Path, implementation: dict[str, str]) -> Path:
    """The same SSP with the SSD Components' implementation attribute set (SspBuilder does not write it)."""
    def edit(root):
        for comp in root.iter(f"{{{SSD_NS}}}Component"):
            if comp.get("name") in implementation:
                comp.set("implementation", implementation[comp.get("name")])
    return _edit_xml_in_zip(ssp, "SystemStructure.ssd", edit)


def _plan(ssp, **flags):
    """build_plan over an SSP with the given flags (lenient, implementation)."""
    from master.plan import build_plan
    from master.ssp.archive import open_scenario
    from master.ssp.parser import read_ssd
    src = open_scenario(ssp)
    try:
        return build_plan(read_ssd(src.ssd_path, src.root, shown_root=src.shown_root), str(ssp), **flags)
    finally:
        src.close()


def _single(tmp_path, fmu, name, stop, step, implementation=None, **params) -> Path:
    b = SspBuilder(name, stop=stop, step=step)
    b.add_component(name, fmu, params=params or None)
    ssp = b.write(tmp_path / f"{name}.ssp")
    return _with_implementation(ssp, {name: implementation}) if implementation else ssp


# -- 2. an FMU that asks to terminate the simulation ends the run there, normally -----------------------------
@pytest.mark.parametrize("version,implementation", [("fmi2", "CoSimulation"), ("fmi2", "ModelExchange"),
                                                    ("fmi3", "CoSimulation")])
def test_stair_ends_the_run_where_it_asks_to_terminate(tmp_path, reference_fmus, version, implementation):
    # Stair counts the seconds and sets terminateSimulation when the counter reaches 10 (at t = 9); the
    # reference results end there
    ref = _reference(reference_fmus, "Stair")
    ssp = _single(tmp_path, reference_fmus / version / "Stair.fmu", "stair", 10.0, 0.2, implementation)
    meta, df = _run(ssp, tmp_path / "out")
    assert meta["outcome"] == "completed" and "error" not in meta
    assert meta["ended_early"] == {"time": pytest.approx(ref["time"].iloc[-1]),
                                   "reason": "component stair asked to terminate the simulation"}
    assert meta["fmus"]["stair"]["kind"] == implementation
    np.testing.assert_allclose(df["time"], ref["time"], atol=1e-9)
    assert list(df["stair.counter"]) == list(ref["counter"])


@pytest.mark.parametrize("kind,inprocess", [("c2", True), ("py", True), ("py", False)])
def test_a_discard_with_fmi2_terminated_ends_the_run_with_its_results(tmp_path, test_fmus, kind, inprocess):
    # Faulty mode 2 discards the step from 0.5 (its first to end after fail_time) and then reports
    # fmi2Terminated (pythonfmu's binary does for every Discard; in process the same): the run ends after
    # that master step; y stays at the last successful time, 0.5
    ssp = _single(tmp_path, test_fmus[f"{kind}:Faulty"], "f", 1.0, 0.1, mode=2, fail_time=0.5)
    meta, df = _run(ssp, tmp_path / "out", inprocess=inprocess)
    assert meta["outcome"] == "completed"
    assert meta["ended_early"] == {"time": pytest.approx(0.6),
                                   "reason": "component f asked to terminate the simulation"}
    np.testing.assert_allclose(df["time"], np.arange(7) * 0.1, atol=1e-12)
    np.testing.assert_allclose(df["f.y"], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5], atol=1e-12)
    assert "illegal call sequence" not in (tmp_path / "out" / "fmu.log").read_text()


# -- 3. after Error, FMI allows freeInstance only -------------------------------------------------------------
def test_no_terminate_after_an_fmu_error(tmp_path, test_fmus):
    ssp = _single(tmp_path, test_fmus["c2:Faulty"], "f", 1.0, 0.1, mode=1, fail_time=0.5)
    with pytest.raises(FmuError, match="doStep returned Error"):
        master.run(ssp, output=tmp_path / "out")
    log = (tmp_path / "out" / "fmu.log").read_text()
    assert "injected error in doStep" in log
    assert "illegal call sequence" not in log, log


# -- 1. FMI 2.0 model exchange: discrete inputs are set in event mode -----------------------------------------
def _feedthrough_me(tmp_path, reference_fmus, test_fmus=None) -> SspBuilder:
    b = SspBuilder("ft", stop=1.5, step=0.1, algorithm="gauss-seidel")
    b.add_component("ft", reference_fmus / "fmi2" / "Feedthrough.fmu",
                    connectors=[(f"{name}_{kind}", kind, typ, None) for name, typ in (("Int32", "Integer"),
                                                                                  ("Boolean", "Boolean"))
                                for kind in ("input", "output")])
    if test_fmus is not None:
        b.add_component("src", test_fmus["py:Types"])
        b.connect("src", "counter", "ft", "Int32_input")
        b.connect("src", "b_out", "ft", "Boolean_input")
    return b


def test_me_connected_integer_and_boolean_inputs(tmp_path, reference_fmus, test_fmus):
    ssp = _with_implementation(_feedthrough_me(tmp_path, reference_fmus, test_fmus).write(tmp_path / "ft.ssp"),
                               {"ft": "ModelExchange"})
    meta, df = _run(ssp, tmp_path / "out")
    assert meta["outcome"] == "completed" and meta["fmus"]["ft"]["kind"] == "ModelExchange"
    # Gauss-Seidel, src first: after k steps its counter is k and Feedthrough passes it on in the same step;
    # b_out = not b_in = true from initialization on
    assert list(df["src.counter"]) == list(range(16))
    assert list(df["ft.Int32_output"]) == list(range(16))
    assert df["ft.Boolean_output"].astype(str).str.lower().eq("true").all()
    assert "illegal call sequence" not in (tmp_path / "out" / "fmu.log").read_text().lower()


class _Signal(Manipulator):
    """Drives an unconnected input from a table (the value of the last row at or before t)."""

    def __init__(self, target, times, values):
        self.target, self.times, self.values = target, np.asarray(times), list(values)

    def before_step(self, n, t):
        k = int(np.searchsorted(self.times, t + 1e-12, side="right")) - 1
        self.ctx.set_value(self.target, int(self.values[k]))


def test_me_integer_input_follows_the_reference_input_signal(tmp_path, reference_fmus):
    signal = _reference(reference_fmus, "Feedthrough", "in")       # Int32: -2**31 until t = 1, then 2**31 - 1
    ssp = _with_implementation(_feedthrough_me(tmp_path, reference_fmus).write(tmp_path / "ft.ssp"),
                               {"ft": "ModelExchange"})
    master.run(ssp, output=tmp_path / "out", record=["ft.Int32_output"],
               manipulators=[_Signal("ft.Int32_input", signal["time"], signal["Int32_input"])])
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    # the value set before the step from t reaches the output at t + h; the first row is the start value
    times = df["time"].to_numpy()
    expected = [0] + [int(signal["Int32_input"][np.searchsorted(signal["time"], t + 1e-12, side="right") - 1])
                      for t in times[:-1]]
    assert list(df["ft.Int32_output"]) == expected
    assert expected[1] == -2**31 and expected[-1] == 2**31 - 1


# -- 5. the SSP implementation attribute chooses the kind ---------------------------------------------------
def _within_crosscheck_band(df, ref, prefix) -> None:
    """The FMI cross-check rule: within 10 % of each signal's range after resampling onto the reference."""
    for col in ref.columns[1:]:
        got = np.interp(ref["time"], df["time"], df[f"{prefix}.{col}"])
        band = 0.1 * (ref[col].max() - ref[col].min())
        assert np.max(np.abs(got - ref[col])) <= band, col


@pytest.mark.parametrize("implementation", ["ModelExchange", "CoSimulation"])
def test_implementation_attribute_runs_the_kind_asked_for(tmp_path, reference_fmus, implementation):
    # The reference results are the co-simulation's (forward Euler, step 0.01); CVode's exact solution of
    # model exchange drifts out of phase with them, past the band after about 15 of the 20 s: 10 s compared
    stop = 10.0
    ref = _reference(reference_fmus, "VanDerPol")
    ref = ref[ref["time"] <= stop + 1e-9]
    ssp = _single(tmp_path, reference_fmus / "fmi2" / "VanDerPol.fmu", "m", stop, 0.01, implementation)
    meta, df = _run(ssp, tmp_path / "out")
    assert meta["outcome"] == "completed" and meta["fmus"]["m"]["kind"] == implementation
    _within_crosscheck_band(df, ref, "m")
    exact = np.array_equal(df["m.x1"].to_numpy(), ref["x1"].to_numpy())
    assert exact == (implementation == "CoSimulation")        # the kind that ran, seen in the numbers too


def test_implementation_the_fmu_does_not_offer_is_refused(tmp_path, test_fmus):
    ssp = _single(tmp_path, test_fmus["c2:Gain"], "g", 1.0, 0.1, "ModelExchange")
    with pytest.raises(ScenarioError, match="implementation ModelExchange is asked for, but the FMU offers "
                                            "CoSimulation only"):
        master.run(ssp, output=None)


def test_build_plan_takes_the_implementation_over_the_ssd(tmp_path, reference_fmus):
    ssp = _single(tmp_path, reference_fmus / "fmi2" / "VanDerPol.fmu", "vdp", 1.0, 0.1, "CoSimulation")
    assert _plan(ssp).fmus["vdp"].kind == "CoSimulation"
    assert _plan(ssp, implementation={"vdp": "ModelExchange"}).fmus["vdp"].kind == "ModelExchange"
    with pytest.raises(ScenarioError, match="implementation given for unknown component nope"):
        _plan(ssp, implementation={"nope": "ModelExchange"})


# -- 4. optional functions looked up when used, under their pre-release names too -------------------------------
def test_fmu_without_optional_functions_and_with_pre_release_names_runs(tmp_path, test_fmus):
    import fmu_factory
    fmu = fmu_factory.build_c_fmu("GainPreRelease", tmp_path / "fmus")
    b = SspBuilder("pre", stop=0.3, step=0.1)
    b.add_component("g", fmu, params={"k": 3.0})
    b.add_component("i", test_fmus["c2:Integrator"], params={"x0": 1.0})
    b.connect("i", "y", "g", "u")
    meta, df = _run(b.write(tmp_path / "pre.ssp"), tmp_path / "out", algorithm="gauss-seidel")
    assert meta["outcome"] == "completed"
    np.testing.assert_allclose(df["g.y"], 3.0 * df["i.y"], atol=1e-12)

    from master.fmi.cache import load_fmu
    from master.fmi.fmpy_adapter import load_library
    lib = load_library("fmi2cs", "g", load_fmu(fmu), str(fmu), "GainPreRelease")
    assert lib.get("fmi2GetFMUstate") is None                       # left out: an optional function
    assert lib.get("fmi2DeSerializeFMUstate") is not None            # found under its pre-release name


# -- 6. lenient reading of a modelDescription.xml ---------------------------------------------------------
def _with_duplicate_variable(src: Path, dst: Path) -> Path:
    """The FMU with its parameter k declared twice (as the Ecos dp_ship FMU declares some variables)."""
    def edit(root):
        variables = root.find("ModelVariables")
        first = next(v for v in variables if v.get("name") == "k")
        variables.append(etree.fromstring(etree.tostring(first)))
    return _edit_xml_in_zip(src, "modelDescription.xml", edit, dst)


def test_lenient_reads_a_duplicate_variable_name_with_a_warning(tmp_path, test_fmus, caplog):
    fmu = _with_duplicate_variable(test_fmus["c2:Gain"], tmp_path / "Gain.fmu")
    b = SspBuilder("dup", stop=0.2, step=0.1)
    b.add_component("g", fmu, connectors=[("k", "parameter", "Real", None), ("y", "output", "Real", None)],
                    params={"k": 2.0})
    ssp = b.write(tmp_path / "dup.ssp")
    with pytest.raises(FmuError, match="invalid modelDescription.xml"):
        master.run(ssp, output=None)               # strict by default
    with caplog.at_level(logging.WARNING, logger="cosim_master"):
        plan = _plan(ssp, lenient=True)
    assert plan.variables["g"]["k"].vr == 0
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("modelDescription.xml is not valid" in w for w in warnings), warnings
    assert any("variable 'k' is declared 2 times (value references 0, 0)" in w for w in warnings), warnings


def _cli(args):
    return run_cli(args)        # in this process: the choice is the subject here, not the program's process


def test_the_command_line_chooses_the_implementation(tmp_path, reference_fmus):
    b = SspBuilder("vdp", stop=1.0, step=0.01)
    b.add_component("vdp", reference_fmus / "fmi2" / "VanDerPol.fmu")
    ssp = b.write(tmp_path / "vdp.ssp")
    for choice, kind in (("me", "ModelExchange"), ("cs", "CoSimulation")):
        out = tmp_path / choice
        r = _cli(["run", str(ssp), "-o", str(out), "--implementation", f"vdp={choice}"])
        assert r.returncode == 0, r.stderr
        assert json.loads((out / "run.json").read_text())["fmus"]["vdp"]["kind"] == kind
    r = _cli(["run", str(ssp), "-o", str(tmp_path / "x"), "--implementation", "vdp=fast"])
    assert r.returncode == 1 and "--implementation: vdp: expected me, cs or any, got 'fast'" in r.stderr
