"""Coupling experiments against closed forms: input extrapolation (observed order of the two-mass oscillator)
and iterative coupling with rollback (the fixed point of an algebraic loop, the monolithic implicit step of the
oscillator, iteration counts of the updates). docs/coupling.md derives what each test expects."""
import numpy as np
import pytest

import master
from master.algorithms.extrapolation import step_mean_weights
from master.ssp.writer import SspBuilder

from analytic import oscillator_step_map, two_mass_exact
from test_algorithms import _oscillator

STEPS = [0.04, 0.02, 0.01]       # h, h/2, h/4 over 10 s (about 1.6 periods of the slower mode)


def _max_error(df) -> float:
    x1, _, x2, _ = two_mass_exact(df["time"].to_numpy())
    return max(np.max(np.abs(df["A.x"] - x1)), np.max(np.abs(df["B.x"] - x2)))


def _observed_orders(tmp_path, fmus, **options) -> tuple[list[float], np.ndarray]:
    errors = [_max_error(master.run(_oscillator(tmp_path, fmus, h), output=None, record=["A.x", "B.x"],
                                    **options).frame) for h in STEPS]
    return errors, np.log2(np.array(errors[:-1]) / np.array(errors[1:]))


def test_step_mean_weights_are_the_adams_bashforth_weights():
    assert step_mean_weights(1) == (1.0,)
    np.testing.assert_allclose(step_mean_weights(2), [1.5, -0.5], rtol=1e-14)
    np.testing.assert_allclose(step_mean_weights(3), [23 / 12, -16 / 12, 5 / 12], rtol=1e-14)
    # a shorter last step (half a step): the mean of y_n + s (y_n - y_{n-1}) over s in [0, 1/2]
    np.testing.assert_allclose(step_mean_weights(2, 0.5), [1.25, -0.25], rtol=1e-14)


@pytest.mark.parametrize("extrapolation, order", [(0, 1.0), (1, 2.0), (2, 2.0)])
def test_jacobi_order_with_extrapolation(tmp_path, test_fmus, extrapolation, order):
    # held inputs: order 1; the mean of the linear or quadratic extrapolant over the step: order 2 (a constant
    # input per step caps it there: docs/coupling.md)
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    errors, slopes = _observed_orders(tmp_path, fmus, algorithm="jacobi", extrapolation=extrapolation)
    assert np.all(np.abs(slopes - order) < 0.15), (errors, slopes)


def test_extrapolation_zero_is_the_compiled_step_bit_for_bit(tmp_path, test_fmus):
    ssp = _oscillator(tmp_path, {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}, 0.05)
    a = master.run(ssp, output=None, record=["*"]).frame
    b = master.run(ssp, output=None, record=["*"], extrapolation=0).frame
    assert a.equals(b)


def test_extrapolation_is_recorded_and_refused_where_it_does_not_apply(tmp_path, test_fmus):
    ssp = _oscillator(tmp_path, {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}, 0.05)
    r = master.run(ssp, output=None, extrapolation=1)
    assert r.metadata["algorithm_info"]["extrapolation"]["weights"] == [1.5, -0.5]
    with pytest.raises(master.CosimError, match="extrapolation.*0, 1,? (or )?2"):
        master.run(ssp, output=None, extrapolation=3)


# -- iterative coupling --------------------------------------------------------------------------------------
def _masses(tmp_path, fmus, h, stop, m1=1.0, kc=1.0, name="osc"):
    b = SspBuilder(name, stop=stop, step=h)
    b.add_component("A", fmus["MassA"], params={"x0": 1.0, "m": m1})
    b.add_component("B", fmus["MassB"], params={"kc": kc})
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / f"{name}.ssp")


def _monolithic_implicit_steps(n_steps, h, m1=1.0, kc=1.0, k1=1.0, k2=1.0, m2=1.0):
    """Rows [x1, v1, x2, v2] of the implicit coupled step: both FMUs step with their inputs held at the values
    of the step's end, F = kc (x2' - x1') on A and x_in = x1' on B (x' = value after the step). With the exact
    step maps [x1, v1]' = PA z1 + qA F and [x2, v2]' = PB z2 + qB kc x1' this is linear in (F, x1'):
        x1' - qA[0] F = PA[0] z1,    F - kc (qB[0] kc - 1) x1' = kc PB[0] z2."""
    PA, qA = oscillator_step_map(m1, k1, h)
    PB, qB = oscillator_step_map(m2, k2 + kc, h)
    z = np.array([1.0, 0.0, 0.0, 0.0])
    rows = [z]
    for _ in range(n_steps):
        z1, z2 = z[:2], z[2:]
        lhs = np.array([[1.0, -qA[0]], [-kc * (qB[0] * kc - 1.0), 1.0]])
        x1_end, force = np.linalg.solve(lhs, [PA[0] @ z1, kc * PB[0] @ z2])
        z = np.concatenate([PA @ z1 + qA * force, PB @ z2 + qB * kc * x1_end])
        rows.append(z)
    return np.array(rows)


@pytest.mark.parametrize("update", ["fixed-point", "aitken", "iqn-ils"])
@pytest.mark.parametrize("m1, kc", [(1.0, 1.0), (0.1, 1000.0)])
def test_iterative_coupling_reaches_the_monolithic_implicit_step(tmp_path, test_fmus, update, m1, kc):
    h, n = 0.01, 100
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    r = master.run(_masses(tmp_path, fmus, h, n * h, m1, kc), output=None, algorithm="iterative",
                   coupling_update=update, coupling_tol=1e-12, coupling_max_iter=100,
                   record=["A.x", "A.v", "B.x", "B.v"])
    expected = _monolithic_implicit_steps(n, h, m1, kc)
    got = r.frame[["A.x", "A.v", "B.x", "B.v"]].to_numpy()
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    info = r.metadata["algorithm_info"]
    assert info["not_converged_steps"] == 0 and info["steps"] == n and info["loops_broken_at"] == ["B.F -> A.F"]


def test_aitken_and_iqn_ils_need_fewer_iterations_than_fixed_point_on_a_stiff_coupling(tmp_path, test_fmus):
    # coupling spring 1000x stiffer, light mass A: the fixed-point map contracts by about 0.5 per iteration
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    ssp = _masses(tmp_path, fmus, 0.01, 1.0, m1=0.1, kc=1000.0)
    mean = {}
    for update in ("fixed-point", "aitken", "iqn-ils"):
        info = master.run(ssp, output=None, algorithm="iterative", coupling_update=update,
                          coupling_max_iter=200).metadata["algorithm_info"]
        assert info["not_converged_steps"] == 0
        mean[update] = info["iterations_mean"]
    # one loop value: Aitken is the secant method and IQN-ILS with one column the same, exact for this linear
    # map after two updates (3 evaluations); fixed point needs ~30 (measured 29.8 mean, 37 max)
    assert mean["aitken"] == mean["iqn-ils"] == 3.0 and mean["fixed-point"] > 20


def test_iterative_coupling_solves_an_algebraic_loop_of_two_feedthrough_fmus(tmp_path, test_fmus, reference_fmus):
    # MassB's F = kc (x - x_in) feeds the Reference FMU Feedthrough (output = input), whose output comes back
    # as x_in = a * F: per step the loop's fixed point is x_in = a kc x(t+h), with x(t+h) = PB[0] z + qB[0] kc x_in
    a, kc, h, n = 0.5, 1.0, 0.05, 40
    b = SspBuilder("loop", stop=n * h, step=h)
    b.add_component("B", test_fmus["c2:MassB"], params={"kc": kc, "x0": 1.0})
    b.add_component("f", reference_fmus / "fmi2" / "Feedthrough.fmu")
    b.connect("B", "F", "f", "Float64_continuous_input")
    b.connect("f", "Float64_continuous_output", "B", "x_in", factor=a)
    r = master.run(b.write(tmp_path / "loop.ssp"), output=None, algorithm="iterative", coupling_tol=1e-13,
                   record=["B.x", "B.F", "f.Float64_continuous_output"])
    PB, qB = oscillator_step_map(1.0, 1.0 + kc, h)
    z, xs, forces = np.array([1.0, 0.0]), [1.0], [kc * 1.0 / (1 + a * kc)]
    for _ in range(n):
        x_in = a * kc * (PB[0] @ z) / (1.0 - a * kc * (qB[0] * kc - 1.0))
        z = PB @ z + qB * kc * x_in
        xs.append(z[0])
        forces.append(x_in / a)
    df = r.frame
    np.testing.assert_allclose(df["B.x"], xs, rtol=0, atol=1e-11)
    np.testing.assert_allclose(df["B.F"], forces, rtol=0, atol=1e-11)
    np.testing.assert_allclose(df["f.Float64_continuous_output"], df["B.F"], rtol=0, atol=1e-11)
    assert r.metadata["algorithm_info"]["iterations_max"] <= 4


def test_iterative_coupling_names_the_fmus_that_cannot_roll_back_before_the_first_step(tmp_path, test_fmus):
    from test_algorithms import _chain
    with pytest.raises(master.CosimError) as e:
        master.run(_chain(tmp_path, test_fmus, 0.05, -2.0, -0.3, 0.2), output=None, algorithm="iterative")
    msg = str(e.value)
    assert "\n" not in msg and "I1, G, I2 cannot save and restore" in msg
    assert e.value.result.metadata.get("steps_done", 0) == 0


def test_iterative_settings_are_checked(tmp_path, test_fmus):
    ssp = _masses(tmp_path, {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}, 0.1, 0.2)
    with pytest.raises(master.CosimError, match="coupling-update: must be one of fixed-point, aitken, iqn-ils, "
                                                "got 'newton'"):
        master.run(ssp, output=None, algorithm="iterative", coupling_update="newton")
    with pytest.raises(master.CosimError, match="does not apply to the iterative algorithm"):
        master.run(ssp, output=None, algorithm="iterative", extrapolation=1)


# -- iterative coupling with inputs interpolated over the step (--coupling-interpolation 1) ---------------------
def _trapezoidal_map(h, m1=1.0, kc=1.0, k1=1.0, k2=1.0, m2=1.0) -> np.ndarray:
    """The 4 x 4 map z_n -> z_{n+1} (z = [x1, v1, x2, v2]) of the trapezoidal coupled step: A steps with F held
    at (F_n + F') / 2, F = kc (x2 - x1) at both ends, B with x_in held at (x1_n + x1') / 2. With the exact step
    maps this is linear in the end positions (x1', x2'):
        (1 + qA[0] kc / 2) x1' - qA[0] kc / 2 x2' = PA[0] z1 + qA[0] kc / 2 (x2 - x1)
        -qB[0] kc / 2 x1' + x2' = PB[0] z2 + qB[0] kc / 2 x1."""
    PA, qA = oscillator_step_map(m1, k1, h)
    PB, qB = oscillator_step_map(m2, k2 + kc, h)
    lhs = np.array([[1.0 + qA[0] * kc / 2, -qA[0] * kc / 2], [-qB[0] * kc / 2, 1.0]])
    columns = []
    for z in np.eye(4):
        z1, z2 = z[:2], z[2:]
        x1_end, x2_end = np.linalg.solve(lhs, [PA[0] @ z1 + qA[0] * kc / 2 * (z2[0] - z1[0]),
                                               PB[0] @ z2 + qB[0] * kc / 2 * z1[0]])
        force = kc / 2 * ((z2[0] - z1[0]) + (x2_end - x1_end))
        columns.append(np.concatenate([PA @ z1 + qA * force, PB @ z2 + qB * kc * (z1[0] + x1_end) / 2]))
    return np.array(columns).T


@pytest.mark.parametrize("m1, kc, h", [(1.0, 1.0, 0.05), (1.0, 1000.0, 0.02)])
def test_interpolated_iteration_is_the_trapezoidal_coupled_step(tmp_path, test_fmus, m1, kc, h):
    # the run reaches the trapezoidal step's fixed point step by step; its map has spectral radius 1 (energy
    # conserved, where inputs held at the end values give 1.106 on the stiff system at h = 0.02: docs/coupling.md)
    n = 60
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    r = master.run(_masses(tmp_path, fmus, h, n * h, m1, kc), output=None, algorithm="iterative",
                   coupling_interpolation=1, coupling_tol=1e-11, coupling_max_iter=100,
                   record=["A.x", "A.v", "B.x", "B.v"])
    T = _trapezoidal_map(h, m1, kc)
    expected = [np.array([1.0, 0.0, 0.0, 0.0])]
    for _ in range(n):
        expected.append(T @ expected[-1])
    expected = np.array(expected)
    got = r.frame[["A.x", "A.v", "B.x", "B.v"]].to_numpy()
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    assert abs(max(abs(np.linalg.eigvals(T))) - 1.0) < 1e-9
    assert "(u_n + U) / 2" in r.metadata["algorithm_info"]["inputs"]


def test_interpolated_iteration_is_second_order(tmp_path, test_fmus):
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    errors, slopes = _observed_orders(tmp_path, fmus, algorithm="iterative", coupling_interpolation=1)
    assert np.all(np.abs(slopes - 2.0) < 0.15), (errors, slopes)
    held, held_slopes = _observed_orders(tmp_path, fmus, algorithm="iterative")
    assert np.all(np.abs(held_slopes - 1.0) < 0.15) and errors[-1] < held[-1] / 10


def test_a_coupling_iteration_that_does_not_converge_stops_at_the_cap(tmp_path, test_fmus):
    # a light mass A (m = 0.02) on the stiff spring: the fixed-point map of the loop value has a gain above 1, so
    # the iterates grow; the run stops at the first step, at the cap, in one line (it used to go on to NaN)
    fmus = {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}
    ssp = _masses(tmp_path, fmus, 0.01, 1.0, m1=0.02, kc=1000.0)
    with pytest.raises(master.CosimError) as err:
        master.run(ssp, output=None, algorithm="iterative", coupling_update="fixed-point", coupling_max_iter=30)
    msg = str(err.value)
    assert "\n" not in msg and "did not converge" in msg and "after 30 iterations" in msg and "t=0.01" in msg
    assert "--coupling-max-iter" in msg and "nan" not in msg.lower()
    # the same system converges with IQN-ILS (3 sweeps a step)
    info = master.run(ssp, output=None, algorithm="iterative").metadata["algorithm_info"]
    assert info["not_converged_steps"] == 0 and info["iterations_max"] <= 4
