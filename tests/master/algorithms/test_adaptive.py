"""Adaptive communication steps (master/algorithms/adaptive.py) against closed forms: the error against the exact
solution, the fixed step needed for the same accuracy, rejected steps that leave no trace (the result is the exact
product of the accepted steps' maps), steps that end on the record grid, reruns, multi-rate cost, bad settings.
docs/coupling.md gives the measured numbers."""
import dataclasses

import sys
from pathlib import Path
import numpy as np
import pandas as pd
import pytest

import fmu_factory
import master
from coupling_refs import COUPLING, coupling_reference
from master.ssp.writer import SspBuilder

from analytic import chain_exact, two_mass_cosim_steps

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "monitors"))   # test_monitors' annotation

def test_predictor_weights_and_grid_fitting():
    from master.algorithms.adaptive import predictor_weights
    from master.algorithms.step_control import fit_to_grid, gustafsson
    # equal steps: the mean over the next step of the line (quadratic) through the samples is the Adams-Bashforth
    # combination, its value at the step's end the extrapolated line (parabola)
    mean, end = predictor_weights(np.array([0.0, -1.0]))
    np.testing.assert_allclose(mean, [1.5, -0.5], rtol=1e-14)
    np.testing.assert_allclose(end, [2.0, -1.0], rtol=1e-14)
    mean, end = predictor_weights(np.array([0.0, -1.0, -2.0]))
    np.testing.assert_allclose(mean, [23 / 12, -16 / 12, 5 / 12], rtol=1e-14)
    np.testing.assert_allclose(end, [3.0, -3.0, 1.0], rtol=1e-14)
    # uneven: samples of t^2 at t = 0, -0.5, -2 (in units of the step) give its mean 1/3 and end value 1
    mean, end = predictor_weights(np.array([0.0, -0.5, -2.0]))
    y = np.array([0.0, 0.25, 4.0])
    assert abs(mean @ y - 1 / 3) < 1e-14 and abs(end @ y - 1.0) < 1e-14
    # equal steps onto the grid point, never a sliver
    assert fit_to_grid(0.1, 0.04) == 0.1 / 3 and fit_to_grid(0.1, 0.1) == 0.1 and fit_to_grid(0.1, 0.5) == 0.1
    # PI.3.4 keeps the step where 0.9 r^-0.3/q = 1 (r = r_prev): r = 0.9^(q/0.3)
    c = gustafsson(2.0)
    r = 0.9 ** (2.0 / 0.3)
    c.r_prev = r
    assert abs(c.accepted(0.01, r) - 0.01) < 1e-15


def test_the_variable_step_closed_form_agrees_with_the_fixed_step_one():
    from analytic import two_mass_cosim
    fixed = two_mass_cosim(40, 0.05, "jacobi_delayed")
    steps = two_mass_cosim_steps(np.full(40, 0.05), "jacobi_delayed")
    for key in ("x1", "v1", "x2", "v2", "F"):
        np.testing.assert_allclose(steps[key], fixed[key], rtol=0, atol=1e-13)


A1, A2, K = -20.0, -0.5, 1.0      # x1' = -20 x1 + x2, x2' = -0.5 x2 + x1: a fast transient, then a slow decay


@pytest.fixture(scope="module")
def integrator(tmp_path_factory):
    """The C Integrator (one explicit Euler step per doStep) with FMU state get/set, which adaptive needs."""
    fmu_factory.VARIANT_MODELS.setdefault("IntegratorRollback", dataclasses.replace(
        fmu_factory.C_MODELS["Integrator"], name="IntegratorRollback", source="Integrator.c", saves_state=True,
        versions_kinds={(2, "cs")}))
    return fmu_factory.build_c_fmu("IntegratorRollback", tmp_path_factory.mktemp("fmus"))


def _chain(tmp_path, fmu, h, stop=10.0):
    b = SspBuilder("chain", stop=stop, step=h)
    b.add_component("I1", fmu, params={"a": A1, "x0": 1.0})
    b.add_component("I2", fmu, params={"a": A2, "x0": 0.0})
    b.connect("I2", "y", "I1", "u")
    b.connect("I1", "y", "I2", "u", factor=K)
    return b.write(tmp_path / f"chain_{h}.ssp")


def _chain_error(df) -> float:
    x1, x2 = chain_exact(df["time"].to_numpy(), A1, A2, K, 1.0, 0.0)
    return max(np.max(np.abs(df["I1.y"] - x1)), np.max(np.abs(df["I2.y"] - x2)))


def test_adaptive_meets_its_tolerance_with_far_fewer_steps_than_a_fixed_step(tmp_path, integrator):
    # held inputs (K = 0): the estimate is the change of each coupled value over the step, i.e. the largest
    # error of the held input, against a tolerance on the scale of each value's largest magnitude so far; on
    # this contracting system the global error stays below the tolerance (measured 1.0e-2 at 1e-2 with 134
    # steps). A fixed step of 2000 steps (15 times as many) still errs 1.9e-2 (4.6e-3 at 8000: first order):
    # the transient needs small steps, the slow decay after it does not.
    ssp = _chain(tmp_path, integrator, 0.5)
    steps = {}
    for tol in (1e-2, 1e-3):
        r = master.run(ssp, output=None, algorithm="adaptive", step_rtol=tol, record=["I1.y", "I2.y"])
        info = r.metadata["algorithm_info"]
        error = _chain_error(r.frame)
        assert error <= tol, (tol, error)
        assert info["rejected"] > 0 and info["accepted_above_tolerance"] == 0
        assert info["step_min"] < 1e-3 * tol / 1e-2 and info["step_max"] >= 0.1
        assert info["fmu_calls"] == 2 * (info["steps"] + info["rejected"])
        steps[tol] = (info["steps"], error)
    n_adaptive, error = steps[1e-2]
    fixed = master.run(_chain(tmp_path, integrator, 0.005), output=None, algorithm="jacobi", record=["I1.y", "I2.y"])
    assert 10 / 0.005 >= 10 * n_adaptive and _chain_error(fixed.frame) > 1.5 * error


# -- the two-mass oscillator: every step is an exact linear map (analytic.two_mass_cosim_steps) --------------------
def _masses(tmp_path, test_fmus, h, stop, name="osc", **settings):
    b = SspBuilder(name, stop=stop, step=h, **settings)
    b.add_component("A", test_fmus["c2:MassA"], params={"x0": 1.0})
    b.add_component("B", test_fmus["c2:MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / f"{name}.ssp")


def _run(ssp, out, **options):
    return master.run(ssp, output=out, algorithm="adaptive", record=["A.x", "A.v", "B.x", "B.v", "B.F"], **options)


def test_rejected_steps_leave_no_trace_and_steps_end_on_the_record_grid(tmp_path, test_fmus):
    # a first step of a whole master step at a tight tolerance is rejected several times; if a rollback left
    # anything behind (an FMU state, a buffer) the result would differ from the product of the exact maps of the
    # accepted steps alone (steps.csv) by the size of a step's effect, not by round-off
    ssp = _masses(tmp_path, test_fmus, 0.25, 3.0, record_interval=0.5)
    r = _run(ssp, tmp_path / "out", step_rtol=1e-3, initial_step=0.25)
    info = r.metadata["algorithm_info"]
    assert info["rejected"] >= 3 and info["rollbacks"] == info["rejected"]
    steps = pd.read_csv(tmp_path / "out" / "steps.csv")
    assert len(steps) == info["steps"]
    # every master step's end is a step's end (steps are shortened to land on it), so the record grid is hit
    grid = 0.25 * np.arange(1, 13)
    assert np.min(np.abs(steps["time"].to_numpy()[:, None] - grid[None, :]), axis=0).max() < 1e-12
    # held inputs with the feedthrough output B.F read again at each step's end (consistent samples): the
    # "jacobi" semantics of tests/analytic.py, step by step
    exact = two_mass_cosim_steps(steps["step"].to_numpy(), "jacobi")
    df = r.frame
    np.testing.assert_allclose(df["time"], 0.5 * np.arange(7), rtol=0, atol=0)
    rows = [int(np.argmin(np.abs(exact["time"] - t))) for t in df["time"]]
    for col, key in (("A.x", "x1"), ("A.v", "v1"), ("B.x", "x2"), ("B.v", "v2")):
        np.testing.assert_allclose(df[col], exact[key][rows], rtol=0, atol=1e-12)
    # B.F from the positions at the same time (kc = 1): no step of delay
    np.testing.assert_allclose(df["B.F"], exact["x2"][rows] - exact["x1"][rows], rtol=0, atol=1e-12)


def test_rerun_is_bit_identical(tmp_path, test_fmus):
    ssp = _masses(tmp_path, test_fmus, 0.5, 3.0)
    a = _run(ssp, tmp_path / "a", step_rtol=1e-3, extrapolation=1)
    b = _run(ssp, tmp_path / "b", step_rtol=1e-3, extrapolation=1)
    assert a.frame.equals(b.frame)
    assert (tmp_path / "a" / "steps.csv").read_bytes() == (tmp_path / "b" / "steps.csv").read_bytes()


def test_a_component_on_a_step_multiple_steps_once_per_macro_step(tmp_path, test_fmus):
    # B steps once per two master steps (12 times over 24 master steps, again when the adaptive step it stepped
    # with is rejected), A with every adaptive step; B's outputs appear when its macro step ends, as with jacobi
    ssp = _masses(tmp_path, test_fmus, 0.125, 3.0)
    r = _run(ssp, None, step_rtol=1e-2, step_multiples={"B": 2})
    info = r.metadata["algorithm_info"]
    assert info["steps"] > 24
    assert 0 <= info["fmu_calls"] - (info["steps"] + info["rejected"] + 12) <= info["rejected"]
    x2 = r.frame["B.x"].to_numpy()
    assert np.array_equal(x2[1::2], x2[0:-1:2]) and np.all(x2[2::2] != x2[1::2])


def test_step_doubling_costs_three_sweeps_and_a_rollback_per_step(tmp_path, test_fmus):
    ssp = _masses(tmp_path, test_fmus, 0.5, 3.0)
    info = _run(ssp, None, step_rtol=1e-4, error_estimate="doubling").metadata["algorithm_info"]
    tries = info["steps"] + info["rejected"]
    assert info["fmu_calls"] == 2 * 3 * tries and info["rollbacks"] == tries + info["rejected"]


@pytest.mark.parametrize("options, message", [
    (dict(min_step=0.2, max_step=0.1), "--min-step: the minimum step 0.2 s is larger than the maximum step 0.1 s"),
    (dict(step_rtol=-1e-3), "--step-rtol: must be >= 0, got -0.001"),
    (dict(step_atol=-1.0), "--step-atol: must be >= 0, got -1"),
    (dict(min_step=0.0), "--min-step: must be positive, got 0"),
    (dict(error_estimate="guess"), "--error-estimate: must be one of extrapolation, doubling, got 'guess'"),
])
def test_bad_settings_give_one_line(tmp_path, test_fmus, options, message):
    with pytest.raises(master.CosimError) as e:
        _run(_masses(tmp_path, test_fmus, 0.5, 1.0), None, **options)
    assert message in str(e.value) and "\n" not in str(e.value)

def test_fmus_that_cannot_roll_back_are_named_before_the_first_step(tmp_path, test_fmus):
    from test_algorithms import _chain as chain_of_three
    with pytest.raises(master.CosimError) as e:
        master.run(chain_of_three(tmp_path, test_fmus, 0.05, -2.0, -0.3, 0.2), output=None, algorithm="adaptive")
    msg = str(e.value)
    assert "\n" not in msg and "I1, G, I2 cannot save and restore" in msg and "adaptive" in msg
    assert e.value.result.metadata.get("steps_done", 0) == 0


def test_a_rejected_step_is_restored_bit_for_bit(tmp_path, test_fmus):
    # after a rejected try the master's buffers are bitwise those before it, and the same try again from the
    # restored FMU states gives bitwise the same outputs (the FMUs' states were restored, not approximated)
    from master.algorithms.adaptive import Adaptive
    from master.execution import Execution
    checked = []

    class Probe(Adaptive):
        def _attempt(self, n, t, h, first, saved):
            out = self.rt.out["Real"]
            before = out.copy()
            r, q, extra = super()._attempt(n, t, h, first, saved)
            if r > 1.0:
                after = out.copy()
                saved.restore()
                self.history[:] = self._kept
                assert out.tobytes() == before.tobytes()
                super()._attempt(n, t, h, first, saved)
                assert out.tobytes() == after.tobytes()
                checked.append(h)
            return r, q, extra

    ex = Execution(_masses(tmp_path, test_fmus, 0.5, 2.0), output=None, algorithm="adaptive", step_rtol=1e-4)
    ex.setup()
    ex.algorithm = Probe()
    ex.algorithm.configure(ex.options)
    with ex:
        ex.simulate_until()
    assert len(checked) >= 3


def test_monitors_see_master_steps_and_can_take_components_out(tmp_path, integrator):
    # test_monitors' Threshold monitor on the same system, with adaptive steps: an Integrator with input 1 is
    # exact at any step (x += h), so the expectations of the fixed-step test hold at every master step: 'other'
    # freezes at 0.5 (the algorithm rebuilds without it) and the run ends at 1.0
    from test_monitors import _annotation
    b = SspBuilder("mon", stop=10.0, step=0.1)
    b.add_component("one", integrator, params={"x0": 1.0})
    b.add_component("clock", integrator)
    b.add_component("other", integrator)
    b.connect("one", "y", "clock", "u")
    b.connect("one", "y", "other", "u")
    b.annotations.append(_annotation(watch="clock.y", freeze="other", level="0.45", stop="0.95"))
    r = master.run(b.write(tmp_path / "mon.ssp"), output=None, algorithm="adaptive", record=["clock.y", "other.y"],
                   initial_step=0.03)
    df = r.frame
    np.testing.assert_allclose(df["clock.y"], df["time"], atol=1e-12)
    frozen = df["time"] >= 0.5 - 1e-12
    np.testing.assert_allclose(df.loc[frozen, "other.y"], 0.5, atol=1e-12)
    np.testing.assert_allclose(df.loc[~frozen, "other.y"], df.loc[~frozen, "time"], atol=1e-12)
    assert abs(df["time"].iloc[-1] - 1.0) < 1e-12
    info = r.metadata["algorithm_info"]
    assert info["steps"] > 10 and info["step_min"] < 0.1        # more than one step per master step at first


def test_a_non_finite_value_ends_the_run_with_the_usual_error(tmp_path, integrator):
    # x1 grows by a factor 1e299 per step and overflows: the estimate becomes NaN, which no shorter step can
    # mend; the run stops at once with the finiteness check's error (not after endless minimal steps)
    b = SspBuilder("blowup", stop=1.0, step=0.1)
    b.add_component("I1", integrator, params={"a": 1e300, "x0": 1.0})
    b.add_component("I2", integrator, params={"a": -1.0, "x0": 0.0})
    b.connect("I2", "y", "I1", "u")
    b.connect("I1", "y", "I2", "u")
    with pytest.raises(master.CosimError) as e:
        master.run(b.write(tmp_path / "blowup.ssp"), output=None, algorithm="adaptive")
    assert "non-finite output" in str(e.value) and "\n" not in str(e.value)
    info = e.value.result.metadata["algorithm_info"]
    assert e.value.time < 0.1 and 1 <= info["steps"] < 10 and info["accepted_above_tolerance"] >= 1


def test_held_inputs_on_the_stiff_oscillator_take_the_steps_the_tolerance_asks_for(tmp_path):
    # oscillator_stiff.ssp (kc = 1000): the coupling force swings over +-1000 at ~44.7 rad/s while A.x stays
    # within +-1. With held inputs the estimate of a step is the change of each coupled value over it, h |y'|,
    # against rtol (1e-2 here) times the value's magnitude so far, so the fewest steps that each meet the
    # tolerance number N = integral of max_i |y_i'| / (atol + rtol M_i) dt, from the closed form; the controller
    # (safety 0.9) takes between N and 2 N. A tolerance on |y_i| alone fell to atol where the force crosses
    # zero, and a held feedthrough sample carried the previous step's change that no shorter step reduces:
    # 27685 steps down to the 1e-8 minimum over this second, one accepted above the tolerance.
    ex = coupling_reference("oscillator_exact")
    stop, rtol = 1.0, 1e-2
    t = np.linspace(0.0, stop, 200001)
    x1, v1, x2, v2 = ex.two_mass(t, **ex.STIFF)
    kc = ex.STIFF["kc"]
    force, dforce = kc * (x2 - x1), kc * (v2 - v1)
    rate = np.maximum(np.abs(dforce) / (rtol + rtol * np.maximum.accumulate(np.abs(force))),
                      np.abs(v1) / (rtol + rtol * np.maximum.accumulate(np.abs(x1))))
    fewest = float(np.sum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t)))
    r = master.run(COUPLING / "oscillator_stiff.ssp", output=tmp_path / "out", algorithm="adaptive",
                   step_rtol=rtol, stop_time=stop, record=["A.x", "B.F"])
    info = r.metadata["algorithm_info"]
    assert fewest <= info["steps"] <= 2 * fewest, (fewest, info)
    assert info["accepted_above_tolerance"] == 0 and info["step_min"] > 0.2 / np.max(rate)
    steps = pd.read_csv(tmp_path / "out" / "steps.csv")
    assert len(steps) == info["steps"] and steps["error_estimate"].max() <= 1.0
