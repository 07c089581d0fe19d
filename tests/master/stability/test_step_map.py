"""The coupled step map identified from the FMUs (master/stability) against the closed forms derived by hand in
ssp/coupling/oscillator_step_map.py (docs/coupling.md, "Stability of the coupled step"): the spectral radius of
every scheme on the two-mass oscillators to 1e-6; the realization step on a matrix known beforehand; a plain run
growing at the rate the radius predicts; the sweep's files and its one-line errors."""
import csv
import math
from pathlib import Path

import numpy as np
import pytest

import master
from coupling_refs import coupling_reference
from master.cli import main
from master.errors import CosimError
from master.stability import identify, spectral_radius
from master.stability.step_map import era
from master.stability.sweep import parse_vary, schemes

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"


CLOSED = coupling_reference("oscillator_step_map")
EXACT = coupling_reference("oscillator_exact")
ITERATIVE = dict(coupling_tol=1e-13, coupling_max_iter=200, coupling_update="aitken")

CASES = [  # (ssp, coupling, parameters, algorithm, K, M, step)
    *[("oscillator_fd", "fd", EXACT.OSCILLATOR, a, k, m, h)
      for a, k, m in (("jacobi", 0, 0), ("jacobi", 1, 0), ("jacobi", 2, 0), ("gauss-seidel", 0, 0),
                      ("gauss-seidel", 1, 0), ("gauss-seidel", 1, 1), ("gauss-seidel", 0, 2), ("iterative", 0, 0))
      for h in (0.01, 0.2)],
    *[("oscillator_dd", "dd", EXACT.OSCILLATOR, a, k, m, 0.05)
      for a, k, m in (("jacobi", 0, 0), ("jacobi", 2, 0), ("gauss-seidel", 0, 0), ("gauss-seidel", 1, 1),
                      ("iterative", 0, 0))],
    *[("oscillator_stiff", "fd", EXACT.STIFF, a, k, m, h)
      for a, k, m in (("jacobi", 0, 0), ("jacobi", 1, 0), ("gauss-seidel", 0, 0), ("gauss-seidel", 1, 1),
                      ("iterative", 0, 0))
      for h in (0.005, 0.05)],
]


@pytest.mark.parametrize("ssp,coupling,p,algorithm,k,m,h", CASES,
                         ids=[f"{c[0]}-{c[3]}-K{c[4]}-M{c[5]}-h{c[6]}" for c in CASES])
def test_identified_spectral_radius_is_the_closed_form(ssp, coupling, p, algorithm, k, m, h):
    options = ITERATIVE if algorithm == "iterative" else dict(extrapolation=k, gs_interpolation=m)
    got = identify(COUPLING / f"{ssp}.ssp", algorithm=algorithm, step=h, **options)
    want = CLOSED.spectral_radius(coupling, algorithm, h, p, k, m)
    assert abs(got.spectral_radius - want) < 1e-6, (got.spectral_radius, want, got.settings)


def test_the_closed_forms_subsystem_transition_is_the_exact_motion():
    # one half alone (kc = 0) over a step is the harmonic motion of oscillator_exact's modal solution
    phi, gamma = CLOSED.transition(1.0, 1.0, 0.3)
    x1, v1, _, _ = EXACT.two_mass(0.3, 1.0, 1.0, 1.0, 1.0, 0.0, 0.7, -0.2, 0.0, 0.0)
    np.testing.assert_allclose(phi @ [0.7, -0.2], [x1, v1], atol=1e-14)
    # a constant force f moves the equilibrium to f / K: starting there, nothing moves
    np.testing.assert_allclose(phi @ [2.0, 0.0] + gamma * 2.0, [2.0, 0.0], atol=1e-14)


def test_the_closed_forms_agree_with_the_converged_implicit_step_on_their_own_terms():
    # iterative = the implicit step: from the closed form's map, the new coupling force must equal
    # kc (x2' - x1') of the new positions it produces (the fixed point the iteration converges to)
    S = CLOSED.step_map("fd", "iterative", 0.1, EXACT.STIFF)
    z = np.array([1.0, 0.3, -0.2, 0.5, 1.0, 0.0])
    z1 = S @ z
    assert z1[5] == pytest.approx(EXACT.STIFF["kc"] * (z1[2] - z1[0]), rel=1e-12)


def test_era_recovers_the_eigenvalues_of_a_known_system():
    rng = np.random.default_rng(3)
    eig = [0.97 * np.exp(0.3j), 0.97 * np.exp(-0.3j), 1.05, -0.4]
    A = np.real(np.block([[np.array([[0.97 * np.cos(0.3), -0.97 * np.sin(0.3)],
                                     [0.97 * np.sin(0.3), 0.97 * np.cos(0.3)]]), np.zeros((2, 2))],
                          [np.zeros((2, 2)), np.diag([1.05, -0.4])]]))
    T = rng.normal(size=(4, 4))
    A = T @ A @ np.linalg.inv(T)
    B, C = rng.normal(size=(4, 2)), rng.normal(size=(3, 4))
    markov = [C @ np.linalg.matrix_power(A, k) @ B for k in range(40)]
    for spacing in (1, 3):
        a, s = era(markov, 5, 1e-10, spacing)
        assert a.shape == (4, 4)
        got = sorted(np.linalg.eigvals(a), key=lambda z: (round(abs(z), 6), z.imag))
        want = sorted(eig, key=lambda z: (round(abs(z), 6), np.imag(z)))
        np.testing.assert_allclose(got, want, atol=1e-9)


def test_a_plain_run_grows_at_the_rate_the_spectral_radius_predicts():
    # the stiff oscillator with Jacobi at h = 0.05: radius ~1.578, so the run's amplitude grows by ln(radius) / h
    # per second (9.1/s): measured over two windows of 2 s each from the recorded positions
    h = 0.05
    rho = spectral_radius(COUPLING / "oscillator_stiff.ssp", algorithm="jacobi", step=h)
    res = master.run(COUPLING / "oscillator_stiff.ssp", algorithm="jacobi", step=h, record=["B.x"],
                     allow_nonfinite=True)
    t, x = res.frame["time"].to_numpy(), np.abs(res.frame["B.x"].to_numpy())
    late, early = x[(t > 8) & (t <= 10)].max(), x[(t > 6) & (t <= 8)].max()
    assert math.log(late / early) / 2.0 == pytest.approx(math.log(rho) / h, rel=0.02)


def test_schemes_leave_out_what_an_algorithm_does_not_take():
    got = [s.label for s in schemes(["jacobi", "gauss-seidel", "iterative"], [0, 1], [0, 1])]
    assert got == ["jacobi", "jacobi K=1", "gauss-seidel", "gauss-seidel M=1", "gauss-seidel K=1",
                   "gauss-seidel K=1 M=1", "iterative"]
    with pytest.raises(CosimError, match="fixed-step"):
        schemes(["ecco"])


def test_the_cli_writes_the_table_and_the_figure(tmp_path, capsys):
    out = tmp_path / "stab"
    assert main(["stability", str(COUPLING / "oscillator_fd.ssp"), "--algorithm", "jacobi", "gauss-seidel",
                 "--extrapolation", "0", "1", "--step", "0.05", "0.2", "--vary", "B.kc=1,4", "-o", str(out)]) == 0
    with open(out / "stability.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * 2 * 2 * 2          # values x schemes x steps
    for r in rows:
        p = dict(EXACT.OSCILLATOR, kc=float(r["value"]))
        want = CLOSED.spectral_radius("fd", r["algorithm"], float(r["step"]), p, int(r["extrapolation"]))
        assert float(r["spectral_radius"]) == pytest.approx(want, abs=1e-6)
        assert r["stable"] == str(want <= 1.0 + 1e-9)
    assert (out / "stability.png").stat().st_size > 10_000
    assert "spectral radius" in capsys.readouterr().out


@pytest.mark.parametrize("argv,element", [
    (["--algorithm", "adaptive", "--step", "0.1"], "--algorithm"),
    (["--algorithm", "jacobi", "--step", "0.1", "--vary", "B.kc="], "--vary"),
    (["--algorithm", "jacobi", "--step", "0.1", "--param", "B.nope=3"], "nope"),
])
def test_bad_arguments_are_one_line(tmp_path, capsys, argv, element):
    assert main(["stability", str(COUPLING / "oscillator_fd.ssp"), *argv, "-o", str(tmp_path / "s")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and element in err and "Traceback" not in err


def test_parse_vary():
    assert parse_vary("B.kc=1,10") == ("B.kc", [1.0, 10.0])
    assert parse_vary(None) is None


def test_the_fit_residual_tells_a_linear_map_from_a_nonlinear_one():
    # the quarter car's linear damper: a linear step map explains the responses to round-off; the progressive
    # damper's (d2 dv |dv|) linearization changes over the identification's steps, and the residual says so
    linear = identify(COUPLING / "quarter_car_linear.ssp", algorithm="jacobi", step=0.01, at=1.0)
    nonlinear = identify(COUPLING / "quarter_car_nonlinear.ssp", algorithm="jacobi", step=0.01, at=1.0)
    assert linear.fit_residual < 1e-10 and linear.spectral_radius < 1.0
    assert nonlinear.fit_residual > 1e-3
