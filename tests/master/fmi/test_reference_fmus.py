"""Every Modelica Reference FMU (the FMI standard's own test models, ``shared/reference-fmus``) that fmpy can run
runs here, as co-simulation and, where offered, as model exchange, from its default experiment, within the FMI
cross-check band of its reference results: every signal within 10 % of its range at the reference's time points.

Where a reference cannot be reached, the test says why and compares with the right answer instead:

* BouncingBall and VanDerPol as model exchange: their references are the co-simulation results, forward Euler at
  the FMU's fixed internal step. The exact solutions (the closed form of the bouncing ball, VanDerPol solved here
  with scipy to 1e-12) are themselves outside the band of those references (checked below), so no accurate
  solver reaches them. Model exchange (CVode) is compared with the exact solution over the whole experiment,
  and with forward Euler at the FMU's own step (``solver="euler"``) it reproduces the reference.
* Feedthrough: its reference was made without its input file (every output stays at its start value): run so
  here; driven by ``Feedthrough_in.csv`` it is checked in tests/master/fmi/test_input_files.py.
* Roberts has no reference results (upstream's file is a copy of BouncingBall's): compared with scipy's stiff
  solver. As model exchange over its whole default experiment (to 1e8 s); as co-simulation to 1 s only,
  because its forward Euler step of 1e-6 s would take 1e14 steps to 1e8 s (fmpy alike).
* Clocks offers scheduled execution only, which neither fmpy nor cosim-master runs: refused in one line.
"""
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from master.errors import CosimError
from master.ssp.writer import SspBuilder

REFERENCE = Path(__file__).resolve().parents[3].parent / "shared" / "reference-fmus"
# compared otherwise, by the tests further down (see the module docstring)
SPECIAL = {("BouncingBall", "ModelExchange"), ("VanDerPol", "ModelExchange"), ("Roberts", "CoSimulation"),
           ("Roberts", "ModelExchange"), ("Clocks", None)}


def _cases() -> list:
    """(version, model, kind) for every FMU and kind in the shared folder (none when it is absent: the fixture
    ``reference_fmus`` then skips the tests that need it)."""
    from fmpy import read_model_description
    cases = []
    for version in ("fmi2", "fmi3"):
        for fmu in sorted((REFERENCE / version).glob("*.fmu")):
            md = read_model_description(str(fmu))
            for kind, part in (("CoSimulation", md.coSimulation), ("ModelExchange", md.modelExchange)):
                if part is not None and (fmu.stem, kind) not in SPECIAL:
                    cases.append(pytest.param(version, fmu.stem, kind, id=f"{version}-{fmu.stem}-{kind}"))
    return cases


def _run(tmp_path, fmu: Path, kind: str, **options) -> pd.DataFrame:
    b = SspBuilder(fmu.stem.lower(), stop=None, step=None)     # nothing but the FMU's default experiment
    b.add_component("m", fmu)
    r = master.run(b.write(tmp_path / f"{fmu.stem}.ssp"), output=None, record=["m.*"],
                   implementation={"m": kind}, **options)
    assert r.metadata["fmus"]["m"]["kind"] == kind
    return r.frame


def _worst(times, got: np.ndarray, ref_times, want: np.ndarray) -> float:
    """The largest deviation after resampling onto the reference's times, in units of the cross-check band."""
    at_ref = np.interp(ref_times, times, got)
    band = 0.1 * max(np.ptp(want), 1e-12) + 1e-9 * np.max(np.abs(want))
    return float(np.max(np.abs(at_ref - want)) / band)


def _numeric(values) -> np.ndarray | None:
    try:
        return np.asarray([float(str(v).strip().lower() == "true") if str(v).strip().lower() in ("true", "false")
                           else float(v) for v in values])
    except ValueError:
        return None


def _within_band(df: pd.DataFrame, ref: pd.DataFrame, fmu: Path) -> None:
    from fmpy import read_model_description
    names = {v.name for v in read_model_description(str(fmu)).modelVariables}
    for col in ref.columns[1:]:
        if col not in names:     # the FMI 2.0 Feedthrough lacks the FMI 3.0 types of the shared reference
            continue
        elements = [c for c in df.columns if c.startswith(f"m.{col}[")]     # an array: one column per element
        if elements:
            want = np.array([[float(x) for x in str(v).split()] for v in ref[col]])
            for j, c in enumerate(elements):
                assert _worst(df["time"], df[c].to_numpy(float), ref["time"], want[:, j]) <= 1.0, c
            continue
        want = _numeric(ref[col])
        if want is None:         # strings and binaries: at every reference time the value in force
            idx = np.searchsorted(df["time"].to_numpy(), ref["time"].to_numpy() - 1e-9)
            got = [v.hex() if isinstance(v, bytes) else str(v) for v in df[f"m.{col}"].to_numpy()[idx]]
            assert got == [str(v) for v in ref[col]], col
            continue
        assert _worst(df["time"], _numeric(df[f"m.{col}"]), ref["time"], want) <= 1.0, col


@pytest.mark.parametrize("version,model,kind", _cases())
def test_reference_fmu_within_the_crosscheck_band(tmp_path, reference_fmus, version, model, kind):
    fmu = reference_fmus / version / f"{model}.fmu"
    _within_band(_run(tmp_path, fmu, kind), pd.read_csv(reference_fmus / "ref" / f"{model}_out.csv"), fmu)


# -- references made by forward Euler, which model exchange does not reach -----------------------------------
def _bouncing_ball_exact(t: np.ndarray) -> np.ndarray:
    """Height and speed of the Reference FMU's ball (h0 = 1, g = 9.81, e = 0.7; a rebound slower than 0.1 ends
    the bouncing) at times t: free fall between impacts, v := -e v at each."""
    g, e, v_min = 9.81, 0.7, 0.1
    impacts, tk, vk = [], np.sqrt(2.0 / g), e * np.sqrt(2.0 * g)
    while vk >= v_min:
        impacts.append((tk, vk))
        tk, vk = tk + 2 * vk / g, e * vk
    rest = tk
    out = np.empty((len(t), 2))
    for i, ti in enumerate(t):
        if ti >= rest:
            out[i] = 0.0, 0.0
            continue
        before = [(a, v) for a, v in impacts if a <= ti]
        if not before:
            out[i] = 1.0 - g * ti * ti / 2, -g * ti
        else:
            a, v = before[-1]
            s = ti - a
            out[i] = v * s - g * s * s / 2, v - g * s
    return out


def _van_der_pol_exact(t: np.ndarray) -> np.ndarray:
    """x0, x1 of x0' = x1, x1' = mu (1 - x0^2) x1 - x0 (mu = 1, x(0) = (2, 0)), solved to 1e-12."""
    from scipy.integrate import solve_ivp
    sol = solve_ivp(lambda _, x: [x[1], (1 - x[0] ** 2) * x[1] - x[0]], (0.0, float(t[-1])), [2.0, 0.0],
                    method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    return sol.y.T


EULER_REFERENCES = {  # model -> (exact solution, the reference's columns, the FMU's fixed Euler step)
    "BouncingBall": (_bouncing_ball_exact, ("h", "v"), 1e-3),
    "VanDerPol": (_van_der_pol_exact, ("x0", "x1"), 1e-2),
}


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("model", sorted(EULER_REFERENCES))
def test_model_exchange_where_the_reference_is_forward_euler(tmp_path, reference_fmus, version, model):
    exact, cols, euler_step = EULER_REFERENCES[model]
    ref = pd.read_csv(reference_fmus / "ref" / f"{model}_out.csv")
    fmu = reference_fmus / version / f"{model}.fmu"
    right = exact(ref["time"].to_numpy())
    # why: the exact solution itself is outside the band of the reference (the Euler bounces drift; VanDerPol's
    # Euler cycle runs out of phase), so no accurate solver can be within it
    assert max(_worst(ref["time"], right[:, j], ref["time"], ref[c].to_numpy()) for j, c in enumerate(cols)) > 1
    # model exchange with CVode: within the band of the exact solution over the whole experiment
    df = _run(tmp_path, fmu, "ModelExchange")
    for j, c in enumerate(cols):
        assert _worst(df["time"], df[f"m.{c}"].to_numpy(), ref["time"], right[:, j]) <= 1.0, c
    # and with the reference's own method, forward Euler at the FMU's fixed step, the reference itself
    _within_band(_run(tmp_path, fmu, "ModelExchange", solver="euler", solver_step=euler_step), ref, fmu)


# -- Roberts: no reference results ----------------------------------------------------------------------------
def _roberts_exact(t: np.ndarray, start: float) -> np.ndarray:
    """y1, y2, y3 of Robertson's kinetics (y3 = 1 - y1 - y2, as the FMU computes it) from (1, 0) at ``start``,
    by scipy's stiff Radau to 1e-10."""
    from scipy.integrate import solve_ivp

    def rhs(_, y):
        y3 = 1.0 - y[0] - y[1]
        return [-0.04 * y[0] + 1e4 * y[1] * y3, 0.04 * y[0] - 1e4 * y[1] * y3 - 3e7 * y[1] ** 2]
    sol = solve_ivp(rhs, (start, float(t[-1])), [1.0, 0.0], method="Radau", rtol=1e-10, atol=[1e-14, 1e-16],
                    t_eval=t)
    return np.column_stack([sol.y[0], sol.y[1], 1.0 - sol.y[0] - sol.y[1]])


@pytest.mark.parametrize("kind,options", [("ModelExchange", {}), ("CoSimulation", {"stop_time": 1.0})])
def test_roberts_against_a_stiff_solver(tmp_path, reference_fmus, kind, options):
    df = _run(tmp_path, reference_fmus / "fmi3" / "Roberts.fmu", kind, **options)
    t = df["time"].to_numpy()
    assert t[-1] == pytest.approx(options.get("stop_time", 1e8))
    right = _roberts_exact(t, t[0])
    for j, c in enumerate(("y1", "y2", "y3")):
        assert _worst(t, df[f"m.{c}"].to_numpy(), t, right[:, j]) <= 1.0, c


def test_clocks_scheduled_execution_is_refused_in_one_line(tmp_path, reference_fmus):
    import fmpy
    fmu = reference_fmus / "fmi3" / "Clocks.fmu"
    with pytest.raises(Exception, match="not supported"):
        fmpy.simulate_fmu(str(fmu))                # fmpy cannot run it either
    b = SspBuilder("clocks", stop=None, step=None)
    b.add_component("m", fmu)
    with pytest.raises(CosimError, match="offers FMI 3.0 scheduled execution only .* which is not supported"):
        master.run(b.write(tmp_path / "clocks.ssp"), output=None)


def test_an_fmu_with_clocks_gets_an_ssd_of_its_other_variables(tmp_path, reference_fmus):
    """SSP 1.0 knows no clock type (SystemStructureCommon: Real, Integer, Boolean, String, Enumeration, Binary):
    the SSD the builder writes (validated against the schema as it is written) lists every input and output of
    Clocks.fmu but its four Clock variables."""
    import zipfile

    from lxml import etree
    fmu = reference_fmus / "fmi3" / "Clocks.fmu"
    b = SspBuilder("clocks", stop=None, step=None)
    b.add_component("m", fmu)
    ssd = etree.fromstring(zipfile.ZipFile(b.write(tmp_path / "clocks.ssp")).read("SystemStructure.ssd"))
    md = etree.fromstring(zipfile.ZipFile(fmu).read("modelDescription.xml"))
    expected = {(v.get("name"), v.get("causality")) for v in md.find("ModelVariables")
                if v.get("causality") in ("input", "output") and v.tag != "Clock"}
    assert len(expected) == 7       # the ticks, the result and output3 outputs, input2
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription"}
    written = {(c.get("name"), c.get("kind")) for c in ssd.iterfind(".//ssd:Component/ssd:Connectors/ssd:Connector", ns)}
    assert written == expected
