"""FMI 1.0 co-simulation FMUs as components: the test FMUs c1:* are built from the same model files as their
FMI 2.0 twins (tests/fmus_c/fmi1_framework.c), so a system gives the same values whichever version runs it."""

import numpy as np
import pytest
from fmpy.validation import validate_fmu

import fmu_factory
import master
from cli_in_process import run_cli
from master.errors import CosimError, ScenarioError
from master.fmi.cache import load_fmu
from master.fmi.factory import choose_kind, slave_class
from master.fmi.fmi1 import Fmi1Slave
from master.ssp.writer import SspBuilder

@pytest.fixture(scope="module")
def test_fmus(test_fmus, tmp_path_factory):
    """The session's test FMUs and the FMI 1.0 ones (c1:*), which are not among its keys."""
    root = tmp_path_factory.mktemp("fmi1")
    fmi1 = {key: fmu_factory.build_by_key(key, root) for key in fmu_factory.FMI1_KEYS}
    return {**{key: test_fmus[key] for key in ("c2:Integrator", "c2:Gain")}, **fmi1}


@pytest.mark.parametrize("key", fmu_factory.FMI1_KEYS)
def test_fmi1_test_fmus_validate(test_fmus, key):
    assert validate_fmu(str(test_fmus[key])) == []


H, K, A1, A2 = 0.05, -2.0, -0.3, 0.2
RECORD = ["I1.y", "G.y", "I2.y"]


def _chain(tmp_path, test_fmus, integrator="c1", gain="c1", name="chain"):
    """I1 -> G -> I2 -> I1, as tests/master/algorithms/test_algorithms.py::_chain."""
    b = SspBuilder(name, stop=2.0, step=H)
    b.add_component("I1", test_fmus[f"{integrator}:Integrator"], params={"a": A1, "x0": 1.0})
    b.add_component("G", test_fmus[f"{gain}:Gain"], params={"k": K})
    b.add_component("I2", test_fmus[f"{integrator}:Integrator"], params={"a": A2, "x0": 0.5})
    b.connect("I1", "y", "G", "u")
    b.connect("G", "y", "I2", "u")
    b.connect("I2", "y", "I1", "u")
    return b.write(tmp_path / f"{name}.ssp")


def _closed_form(rows: int, alg: str) -> np.ndarray:
    """Each Integrator does x += h (a x + u), G.y = k u; state (x1, g, x2) as in test_algorithms."""
    row1 = np.array([1 + H * A1, 0, H])
    if alg == "jacobi":
        J = np.array([row1, [K, 0, 0], [0, H, 1 + H * A2]])
    else:
        J = np.vstack([row1, K * row1, np.array([0, 0, 1 + H * A2]) + H * K * row1])
    s = np.array([1.0, K, 0.5])
    out = [s]
    for _ in range(rows - 1):
        s = J @ s
        out.append(s)
    return np.array(out)


def _run(ssp, **options):
    return master.run(ssp, output=None, record=RECORD, **options).frame


def test_fmi1_cs_fmus_run_as_fmi1_slaves(test_fmus):
    fmu = load_fmu(test_fmus["c1:Integrator"])
    assert fmu.fmi_version == "1.0" and choose_kind(fmu) == "CoSimulation"
    assert slave_class(fmu) is Fmi1Slave
    # FMI 1.0's parameter variability arrives as FMI 2.0's parameter causality, which the plan settles
    assert {v.name: v.causality for v in fmu.md.modelVariables}["a"] == "parameter"
    # DirectDependency read as output dependencies: y = x does not depend on u directly
    assert [(u.variable.name, u.dependencies) for u in fmu.md.outputs] == [("y", [])]


@pytest.mark.parametrize("alg", ["jacobi", "gauss-seidel"])
def test_chain_of_fmi1_fmus_matches_fmi2_and_the_closed_form(tmp_path, test_fmus, alg):
    fmi1 = _run(_chain(tmp_path, test_fmus, "c1", "c1", name="fmi1"), algorithm=alg)
    fmi2 = _run(_chain(tmp_path, test_fmus, "c2", "c2", name="fmi2"), algorithm=alg)
    assert fmi1.equals(fmi2)
    np.testing.assert_allclose(fmi1[RECORD].to_numpy(), _closed_form(len(fmi1), alg), rtol=1e-13, atol=1e-15)


def test_mixed_fmi1_and_fmi2_system(tmp_path, test_fmus):
    mixed = _run(_chain(tmp_path, test_fmus, "c1", "c2", name="mixed"), algorithm="gauss-seidel")
    fmi2 = _run(_chain(tmp_path, test_fmus, "c2", "c2", name="fmi2"), algorithm="gauss-seidel")
    assert mixed.equals(fmi2)


def test_parameter_from_the_ssd_and_the_command_line(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    df = _run(ssp, params={"G.k": 3.0})
    # the SSD sets I1.x0 = 1; G.y = k I1.y with the command line's k at the start
    assert df["I1.y"].iloc[0] == 1.0 and df["G.y"].iloc[0] == 3.0
    out = tmp_path / "out"
    r = run_cli(["run", str(ssp), "-o", str(out), "--param", "G.k=3"])
    assert r.returncode == 0, r.stderr


def _faulty(tmp_path, test_fmus, mode):
    b = SspBuilder("faulty", stop=1.0, step=0.1)
    b.add_component("f", test_fmus["c1:Faulty"], params={"mode": mode, "fail_time": 0.5})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("f", "y", "g", "u")
    return b.write(tmp_path / f"faulty_{mode}.ssp")


@pytest.mark.parametrize("mode,status", [(1, "Error"), (2, "Discard")])
def test_a_failing_step_names_the_component(tmp_path, test_fmus, mode, status):
    with pytest.raises(CosimError) as exc:
        master.run(_faulty(tmp_path, test_fmus, mode), output=None)
    message = str(exc.value)
    assert "\n" not in message and "component f" in message and "t=0.5" in message, message
    assert f"returned {status}" in message, message


def test_a_constant_cannot_be_set_and_a_parameter_can(tmp_path, test_fmus):
    ssp = _chain(tmp_path, test_fmus)
    with pytest.raises(ScenarioError, match="I1.y has causality output"):
        _run(ssp, params={"I1.y": 1.0})
    assert _run(ssp, params={"I2.x0": 2.0})["I2.y"].iloc[0] == 2.0
