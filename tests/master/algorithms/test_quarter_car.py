"""The quarter-car benchmarks with a power bond (ssp/coupling/quarter_car_*.ssp; Sadjina et al. 2017's system):
the shipped reference against a matrix-exponential solution, the FMUs converging to it, and ECCO's gain over
fixed steps at the same number of macro steps (the comparison of the paper, which reports error reductions of up
to 93 %; docs/coupling.md gives the measured table)."""
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import master
from coupling_refs import coupling_reference

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
SIGNALS = ["chassis.z", "chassis.v", "wheel.x", "wheel.v"]


def _reference():
    return coupling_reference("quarter_car_exact")


QX = _reference()


def _errors(result, reference):
    t = result.frame["time"].to_numpy()
    want = reference(t)
    return {c: float(np.max(np.abs(result.frame[c].to_numpy() - want[c]))) for c in SIGNALS}


def test_the_reference_solver_matches_the_matrix_exponential_of_the_linear_system():
    # no bump, the chassis released from a deflection: y' = A y with y = (z, v_C, x_W, v_W)
    c, w = dict(QX.CHASSIS, z0=0.02), dict(QX.WHEEL, bump=0.0)
    A = np.array([[0.0, 1.0, 0.0, -1.0],
                  [-c["k"] / c["m"], -c["d"] / c["m"], 0.0, c["d"] / c["m"]],
                  [0.0, 0.0, 0.0, 1.0],
                  [c["k"] / w["m"], c["d"] / w["m"], -w["k"] / w["m"], -(c["d"] + w["d"]) / w["m"]]])
    t = np.linspace(0.0, 2.0, 41)
    got = QX._solve(c, w, t)
    want = np.array([expm(A * s) @ [0.02, 0.0, 0.0, 0.0] for s in t])
    for k, name in enumerate(SIGNALS):
        np.testing.assert_allclose(got[name], want[:, k], atol=1e-10)


def test_fixed_steps_converge_to_the_reference_at_order_one():
    e = [_errors(master.run(COUPLING / "quarter_car_linear.ssp", algorithm="jacobi", step=h, record=SIGNALS),
                 QX.linear)["wheel.x"] for h in (0.004, 0.002)]
    assert np.log2(e[0] / e[1]) == pytest.approx(1.0, abs=0.15)


@pytest.mark.parametrize("case", ["linear", "nonlinear"])
def test_ecco_beats_fixed_steps_at_the_same_number_of_steps(case):
    # measured: 81 % (linear) and 87 % (nonlinear) less error on the wheel's position at rtol 1e-3
    ssp = COUPLING / f"quarter_car_{case}.ssp"
    reference = getattr(QX, case)
    ecco = master.run(ssp, algorithm="ecco", step_rtol=1e-3, record=SIGNALS)
    steps = ecco.metadata["algorithm_info"]["steps"]
    fixed = master.run(ssp, algorithm="jacobi", step=QX.STOP / steps, record=SIGNALS)
    assert fixed.metadata["fmu_calls"]["do_step_total"] >= ecco.metadata["fmu_calls"]["do_step_total"] - 2
    e_ecco, e_fixed = _errors(ecco, reference), _errors(fixed, reference)
    for name in SIGNALS:
        assert e_ecco[name] < e_fixed[name], name
    assert 1 - e_ecco["wheel.x"] / e_fixed["wheel.x"] > 0.7
    assert "suspension" in ecco.metadata["algorithm_info"]["power_bonds"]


def test_the_shipped_quarter_car_fmus_carry_the_current_sources():
    source = REPO / "fmu_sources" / "coupling"
    for name, files in {"PyWheel": ["PyWheel"], "PyChassis": ["PyChassis", "PyWheel"]}.items():
        with zipfile.ZipFile(COUPLING / "fmus" / f"{name}.fmu") as z:
            for f in files:
                assert z.read(f"resources/{f}.py") == (source / f"{f}.py").read_bytes(), f"{name}.fmu is stale"
