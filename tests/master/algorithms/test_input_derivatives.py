"""Input derivatives (``--input-derivatives 1``): Jacobi hands FMUs that can interpolate inputs the extrapolation
polynomial as value and derivatives (fmi2SetRealInputDerivatives); with 2 the polynomial also matches the
producers' output derivatives (fmi2GetRealOutputDerivatives). Measured against the oscillator's closed form
(ssp/coupling/oscillator_exact.py): order K + 1 with 1 (3 with K = 2 where the step mean gives 2), K + 2 with 2
(hold + slope: 2, linear + slope: 3); the interpolating FMU against an ODE solution with a quadratic input; the
derivative weights by hand; one-line refusals."""
import zipfile
from pathlib import Path

import numpy as np
import pytest

import master
from coupling_refs import coupling_reference
from master.algorithms.extrapolation import derivative_weights, hermite_derivative_weights
from master.cli import main

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
INTERP = COUPLING / "oscillator_fd_interp.ssp"
STEPS = [0.02, 0.01, 0.005]


def _exact():
    return coupling_reference("oscillator_exact")


def _order(**options) -> float:
    fd = _exact().fd
    errors = []
    for h in STEPS:
        r = master.run(INTERP, algorithm="jacobi", step=h, record=["A.x", "B.x"], **options)
        want = fd(r.frame["time"].to_numpy())
        errors.append(max(np.max(np.abs(r.frame[c].to_numpy() - want[c])) for c in ("A.x", "B.x")))
    return float(np.polyfit(np.log(STEPS), np.log(errors), 1)[0])


@pytest.mark.parametrize("k,derivatives,theory", [(2, 1, 3.0), (1, 1, 2.0), (2, 0, 2.0), (0, 2, 2.0), (1, 2, 3.0)])
def test_observed_order_is_the_polynomials_degree_plus_one(k, derivatives, theory):
    # a constant input misses the signal's slope within the step (local O(h^3), order 2 for any K); a polynomial
    # of degree p followed within the step errs by O(h^{p+1}): local O(h^{p+2}), global p + 1, with p = K from
    # K + 1 samples and p = K + 1 when the exact slope at t_n is matched too
    assert _order(extrapolation=k, input_derivatives=derivatives) == pytest.approx(theory, abs=0.15)


def test_derivative_weights_by_hand():
    # slope and curvature at t_n of the polynomial through y_n, y_{n-1}(, y_{n-2}), in units of h
    np.testing.assert_allclose(derivative_weights(2, 1), (1.0, -1.0), atol=1e-14)
    np.testing.assert_allclose(derivative_weights(3, 1), (1.5, -2.0, 0.5), atol=1e-14)
    np.testing.assert_allclose(derivative_weights(3, 2), (1.0, -2.0, 1.0), atol=1e-14)
    assert derivative_weights(2, 2) == (0.0, 0.0)
    # with the slope h y'_n: the line y_n + h y'_n s; the parabola through y_{n-1} with it: p'' = 2 (y_{n-1} - y_n
    # + h y'_n) / h^2
    np.testing.assert_allclose(hermite_derivative_weights(1, 1), (0.0, 1.0), atol=1e-14)
    np.testing.assert_allclose(hermite_derivative_weights(2, 1), (0.0, 0.0, 1.0), atol=1e-14)
    np.testing.assert_allclose(hermite_derivative_weights(2, 2), (-2.0, 2.0, 2.0), atol=1e-14)


def test_the_interpolating_fmu_follows_a_quadratic_input_exactly():
    # MassAInterp alone, m x'' = -k x + F(t) with F = 1 + 0.5 t - 0.2 t^2 / 2 given as value and derivatives:
    # its doStep against scipy's solution of the same ODE
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from scipy.integrate import solve_ivp
    fmu = COUPLING / "fmus" / "MassAInterp.fmu"
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(fmu)
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier="MassAInterp", instanceName="a")
    s.instantiate()
    s.setReal([vr["m"], vr["k"], vr["x0"], vr["v0"]], [2.0, 3.0, 0.4, -0.1])
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.setReal([vr["F"]], [1.0])
    s.setRealInputDerivatives([vr["F"], vr["F"]], [1, 2], [0.5, -0.2])
    s.doStep(0.0, 0.7)
    got = s.getReal([vr["x"], vr["v"]])
    s.setReal([vr["F"]], [1.0])      # derivatives were for that step only: the next one holds F
    s.doStep(0.7, 0.3)
    held = s.getReal([vr["x"], vr["v"]])
    s.terminate()
    s.freeInstance()

    def rhs(t, y, quadratic):
        force = 1.0 + (0.5 * t - 0.1 * t * t if quadratic else 0.0)
        return [y[1], (-3.0 * y[0] + force) / 2.0]
    first = solve_ivp(rhs, (0.0, 0.7), [0.4, -0.1], args=(True,), rtol=1e-12, atol=1e-14).y[:, -1]
    second = solve_ivp(rhs, (0.0, 0.3), first, args=(False,), rtol=1e-12, atol=1e-14).y[:, -1]
    np.testing.assert_allclose(got, first, atol=1e-10)
    np.testing.assert_allclose(held, second, atol=1e-10)


def test_without_derivatives_the_interpolating_ssp_runs_as_the_plain_one_bit_for_bit():
    plain = master.run(COUPLING / "oscillator_fd.ssp", algorithm="jacobi", extrapolation=1, record=["A.x", "B.F"])
    interp = master.run(INTERP, algorithm="jacobi", extrapolation=1, record=["A.x", "B.F"])
    assert np.array_equal(plain.frame[["A.x", "B.F"]].to_numpy(), interp.frame[["A.x", "B.F"]].to_numpy())


def test_the_shipped_interpolating_fmus_carry_the_current_source():
    source = (REPO / "fmu_sources" / "coupling" / "c" / "MassInterp.c").read_bytes()
    for name in ("MassAInterp", "MassBInterp"):
        with zipfile.ZipFile(COUPLING / "fmus" / f"{name}.fmu") as z:
            assert z.read("sources/MassInterp.c") == source, f"{name}.fmu is stale: run fmu_sources/coupling/build.py"


@pytest.mark.parametrize("scenario,argv,words", [
    ("oscillator_fd.ssp", ["--extrapolation", "2"], ["A cannot interpolate inputs", "--input-derivatives"]),
    ("oscillator_fd_interp.ssp", [], ["needs --extrapolation 1 or 2"]),
    ("oscillator_fd.ssp", ["--input-derivatives", "2"], ["A cannot interpolate inputs"]),
    ("oscillator_fd_interp.ssp", ["--algorithm", "gauss-seidel", "--extrapolation", "1"], ["jacobi only"]),
])
def test_refusals_are_one_line(tmp_path, capsys, scenario, argv, words):
    code = main(["run", str(COUPLING / scenario), "--input-derivatives", "1", *argv, "--stop-time", "0.1",
                 "-o", str(tmp_path / "r")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and err.count("\n") == 0, err
    assert all(w in err for w in words), err


def test_an_fmu_refusing_an_order_fails_the_run_naming_it(tmp_path, capsys):
    # K = 2 with the slope is a cubic; MassBInterp takes inputs up to quadratic and says so
    code = main(["run", str(INTERP), "--extrapolation", "2", "--input-derivatives", "2", "-o", str(tmp_path / "r")])
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 1 and "component B" in last and "setting input derivatives" in last and "orders 1 and 2" in last
