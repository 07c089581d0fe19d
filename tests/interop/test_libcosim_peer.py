"""libcosim (via libcosimpy) as an independent peer: it loads hand-made SSPs
with our C FMUs, converges to the monolithic solution and follows the
documented "jacobi_delayed" semantics exactly."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

pytest.importorskip("libcosimpy")

import analytic as an  # noqa: E402
from peers.libcosim_runner import run_libcosim  # noqa: E402
from ssp_helpers import NS_SSC, NS_SSD, NS_SSV, write_ssp  # noqa: E402

MASS_CONNECTIONS = [("A", "x", "B", "x_in"), ("B", "F", "A", "F")]
MASS_VARS = [("A", "x"), ("A", "v"), ("B", "x"), ("B", "v"), ("B", "F")]


@pytest.fixture(scope="module")
def mass_ssp(test_fmus, tmp_path_factory):
    path = tmp_path_factory.mktemp("ssp") / "two_mass.ssp"
    return write_ssp(path, {"A": test_fmus["c2:MassA"], "B": test_fmus["c2:MassB"]}, MASS_CONNECTIONS,
                     {("A", "x0"): 1.0, ("B", "x0"): 0.0}, start=0.0, stop=10.0, step=0.01)


def test_write_ssp_layout(mass_ssp):
    from lxml import etree

    with zipfile.ZipFile(mass_ssp) as zf:
        names = set(zf.namelist())
        ssd = etree.fromstring(zf.read("SystemStructure.ssd"))
    assert {"SystemStructure.ssd", "resources/MassA.fmu", "resources/MassB.fmu"} <= names
    assert ssd.tag == f"{{{NS_SSD}}}SystemStructureDescription"
    ns = {"ssd": NS_SSD, "ssc": NS_SSC, "ssv": NS_SSV}
    comps = ssd.findall("ssd:System/ssd:Elements/ssd:Component", ns)
    assert [c.get("name") for c in comps] == ["A", "B"]
    assert comps[0].get("source") == "resources/MassA.fmu"
    kinds = {c.get("name"): c.get("kind") for c in comps[1].findall("ssd:Connectors/ssd:Connector", ns)}
    assert kinds["x_in"] == "input" and kinds["F"] == "output" and kinds["kc"] == "parameter"
    p = comps[0].find(".//ssv:Parameter[@name='x0']/ssv:Real", ns)
    assert float(p.get("value")) == 1.0
    conns = ssd.findall("ssd:System/ssd:Connections/ssd:Connection", ns)
    assert [(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in conns] == MASS_CONNECTIONS


def test_libcosim_runs_two_masses(mass_ssp):
    df = run_libcosim(mass_ssp, 0.01, 1.0, MASS_VARS)
    assert list(df.columns) == ["time"] + [f"{c}.{v}" for c, v in MASS_VARS]
    assert len(df) == 101
    np.testing.assert_allclose(df["time"], np.arange(101) * 0.01, atol=1e-12)
    # t = 0 row is after initialization: feedthrough F already uses x_in = A.x0
    assert df["A.x"][0] == 1.0 and df["B.x"][0] == 0.0 and df["B.F"][0] == -1.0


def test_libcosim_converges_to_monolithic_solution(mass_ssp):
    errors = []
    for h in (0.04, 0.02, 0.01):
        df = run_libcosim(mass_ssp, h, 5.0, [("A", "x"), ("B", "x")])
        x1, _, x2, _ = an.two_mass_exact(df["time"].to_numpy())
        errors.append(max(np.abs(df["A.x"] - x1).max(), np.abs(df["B.x"] - x2).max()))
    assert errors[-1] < 0.05
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.8) & (ratios < 2.2)), (errors, ratios)  # first order in h


@pytest.mark.parametrize("family", ["c2", "py"])
def test_libcosim_is_jacobi_delayed_two_masses(test_fmus, tmp_path, family):
    ssp = write_ssp(tmp_path / "m.ssp", {"A": test_fmus[f"{family}:MassA"], "B": test_fmus[f"{family}:MassB"]},
                    MASS_CONNECTIONS, {("A", "x0"): 1.0}, stop=3.0, step=0.05)
    h = 0.05
    df = run_libcosim(ssp, h, 3.0, MASS_VARS)
    r = an.two_mass_cosim(len(df) - 1, h, "jacobi_delayed")
    for col, key in [("A.x", "x1"), ("A.v", "v1"), ("B.x", "x2"), ("B.v", "v2"), ("B.F", "F")]:
        np.testing.assert_allclose(df[col], r[key], atol=1e-12, err_msg=col)
    # and it is *not* the feedthrough-resolving Jacobi
    rj = an.two_mass_cosim(len(df) - 1, h, "jacobi")
    assert np.abs(df["A.x"] - rj["x1"]).max() > 1e-3


@pytest.mark.parametrize("parameter_files", [False, True])
def test_libcosim_is_jacobi_delayed_chain(test_fmus, tmp_path, parameter_files):
    a1, a2, k, x10, x20 = -0.5, 0.3, -1.7, 1.2, 0.4
    integ = test_fmus["c2:Integrator"]
    ssp = write_ssp(tmp_path / "chain.ssp", {"I1": integ, "G": test_fmus["c2:Gain"], "I2": integ},
                    [("I1", "y", "G", "u"), ("G", "y", "I2", "u"), ("I2", "y", "I1", "u")],
                    {("I1", "a"): a1, ("I1", "x0"): x10, ("I2", "a"): a2, ("I2", "x0"): x20, ("G", "k"): k},
                    stop=2.0, step=0.1, parameter_files=parameter_files)
    if parameter_files:
        assert "resources/I1.ssv" in zipfile.ZipFile(ssp).namelist()
    df = run_libcosim(ssp, 0.1, 2.0, [("I1", "y"), ("G", "y"), ("I2", "y")])
    r = an.chain_recurrence(len(df) - 1, 0.1, "jacobi_delayed", a1=a1, a2=a2, k=k, x10=x10, x20=x20)
    np.testing.assert_allclose(df["I1.y"], r["I1.y"], atol=1e-12)
    np.testing.assert_allclose(df["G.y"], r["Gain.y"], atol=1e-12)
    np.testing.assert_allclose(df["I2.y"], r["I2.y"], atol=1e-12)


def test_libcosim_integer_and_error(test_fmus, tmp_path):
    ssp = write_ssp(tmp_path / "faulty.ssp", {"F": test_fmus["c2:Faulty"]}, [],
                    {("F", "mode"): 0, ("F", "fail_time"): 0.3}, stop=1.0, step=0.1)
    df = run_libcosim(ssp, 0.1, 1.0, [("F", "y"), ("F", "mode")])
    np.testing.assert_allclose(df["F.y"], df["time"], atol=1e-12)
    assert list(df["F.mode"]) == [0] * 11
    ssp = write_ssp(tmp_path / "faulty1.ssp", {"F": test_fmus["c2:Faulty"]}, [],
                    {("F", "mode"): 1, ("F", "fail_time"): 0.3}, stop=1.0, step=0.1)
    with pytest.raises(RuntimeError, match="step failed"):
        run_libcosim(ssp, 0.1, 1.0, [("F", "y")])
