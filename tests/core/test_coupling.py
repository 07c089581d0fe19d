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
    with pytest.raises(master.CosimError, match="--extrapolation must be 0, 1 or 2"):
        master.run(ssp, output=None, extrapolation=3)
