"""ECCO (master/algorithms/ecco.py) on the two-mass oscillator with a power bond (force B.F -> A.F, velocity
A.v -> B.v_in): the powers it reports against the exact step maps, the residual held at its tolerance by the
controller, energy and position errors against the closed form, libcosim's ECCO on the same system, bad input.
docs/coupling.md derives the expectations and gives the measured numbers."""
import dataclasses

import numpy as np
import pandas as pd
import pytest

import fmu_factory
import master
from master.ssp.power_bonds import power_bonds_annotation
from master.ssp.writer import SspBuilder

from analytic import two_mass_cosim_steps, two_mass_energy, two_mass_exact

BOND = ("spring", ("B", "F", "A", "F"), ("A", "v", "B", "v_in"))
# libcosim's ECCO controller law has its fixed point where safety * eps^-k_I = 1 (eps_prev = eps): the controller
# holds the residual there, just below the tolerance
EPS_STEADY = 0.99 ** (1 / 0.15)


@pytest.fixture(scope="module")
def masses(tmp_path_factory, test_fmus):
    """MassA and MassB with the flow input v_in (the velocity of mass 1, used only for the power at B's port:
    MassB.c unchanged, one variable more in its modelDescription)."""
    fmu_factory.VARIANT_MODELS.setdefault("MassBBond", dataclasses.replace(
        fmu_factory.C_MODELS["MassB"], name="MassBBond", source="MassB.c",
        variables=fmu_factory.C_MODELS["MassB"].variables + [
            fmu_factory._input("v_in", 0.0, "velocity of mass 1 (the flow of the power bond; not in the dynamics)")]))
    return {"MassA": test_fmus["c2:MassA"],
            "MassBBond": fmu_factory.build_c_fmu("MassBBond", tmp_path_factory.mktemp("fmus"))}


def _bonded(tmp_path, masses, h, stop, name="ecco", bonds=(BOND,)):
    b = SspBuilder(name, stop=stop, step=h)
    b.add_component("A", masses["MassA"], params={"x0": 1.0})
    b.add_component("B", masses["MassBBond"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    b.connect("A", "v", "B", "v_in")
    if bonds:
        b.annotations.append(power_bonds_annotation(list(bonds)))
    return b.write(tmp_path / f"{name}.ssp")


RECORD = ["A.x", "A.v", "B.x", "B.v"]


def _ecco(ssp, out, tol, **options):
    return master.run(ssp, output=out, algorithm="ecco", step_rtol=tol, record=RECORD, **options)


def test_the_exact_solution_keeps_its_energy():
    t = np.linspace(0.0, 10.0, 101)
    energy = two_mass_energy(*two_mass_exact(t))
    np.testing.assert_allclose(energy, 1.0, rtol=1e-13)       # E0 = k1 x10^2 / 2 + kc x10^2 / 2 = 1


def test_powers_are_those_of_the_exact_steps_and_the_residual_sits_at_the_tolerance(tmp_path, masses):
    # every ECCO step is a Jacobi step with held inputs, an exact linear map (analytic.two_mass_cosim_steps,
    # "jacobi_delayed"): A holds F from the step before, B holds v_in = v1 from the step before, so
    # P_A = F_{k-1} v1_k and P_B = F_k v1_{k-1}
    r = _ecco(_bonded(tmp_path, masses, 0.5, 10.0), tmp_path / "out", 1e-3)
    steps = pd.read_csv(tmp_path / "out" / "steps.csv")
    exact = two_mass_cosim_steps(steps["step"].to_numpy(), "jacobi_delayed")
    np.testing.assert_allclose(steps["time"], exact["time"][1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(steps["spring.power_a"], exact["F"][:-1] * exact["v1"][1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(steps["spring.power_b"], exact["F"][1:] * exact["v1"][:-1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(steps["spring.energy_residual"],
                               np.cumsum(steps["spring.power_residual"] * steps["step"]), rtol=1e-12, atol=1e-15)
    info = r.metadata["algorithm_info"]
    assert info["energy_residual"]["spring"] == steps["spring.energy_residual"].iloc[-1]
    assert info["rejected"] == info["rollbacks"] == 0 and info["fmu_calls"] == 2 * info["steps"]
    # no step is rejected, so single steps exceed the tolerance; the controller holds the median at its fixed point
    assert abs(np.median(steps["error_estimate"]) - EPS_STEADY) < 0.1


def test_energy_and_position_errors_shrink_as_the_square_root_of_the_tolerance(tmp_path, masses):
    # with atol = rtol the absolute term dominates eps = |dP h| / (atol + rtol |P h|); dP ~ h (held inputs), so
    # eps ~ h^2 / tol: the controller takes h ~ tol^(1/2), and the first-order errors follow it
    ssp = _bonded(tmp_path, masses, 0.5, 10.0)
    drift, error, steps = [], [], []
    for tol in (1e-2, 1e-3, 1e-4):
        r = _ecco(ssp, None, tol)
        df = r.frame
        energy = two_mass_energy(df["A.x"], df["A.v"], df["B.x"], df["B.v"])
        drift.append(np.max(np.abs(energy - energy[0])))
        x1, _, x2, _ = two_mass_exact(df["time"].to_numpy())
        error.append(max(np.max(np.abs(df["A.x"] - x1)), np.max(np.abs(df["B.x"] - x2))))
        steps.append(r.metadata["algorithm_info"]["steps"])
    for values in (drift, error):
        slopes = np.log10(np.array(values[:-1]) / np.array(values[1:]))
        assert np.all(np.abs(slopes - 0.5) < 0.1), (values, slopes)
    assert np.all(np.abs(np.log10(np.array(steps[1:]) / np.array(steps[:-1])) - 0.5) < 0.15), steps


def _libcosim_ecco(masses, stop, tol, h0, h_min, h_max):
    """libcosim's own ECCO (libcosimpy) on the same FMUs and bond: its step ends and, per step, the bond's
    values as its last-value observer reports them (inputs: the values held over the step)."""
    from libcosimpy.CosimAlgorithm import CosimAlgorithm, EccoParams
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    log_output_level(CosimLogLevel.ERROR)
    algorithm = CosimAlgorithm.create_ecco_algorithm(EccoParams(
        safety_factor=0.99, step_size=h0, min_step_size=h_min, max_step_size=h_max, min_change_rate=0.2,
        max_change_rate=1.5, abs_tolerance=tol, rel_tolerance=tol, p_gain=0.2, i_gain=0.15))
    ex = CosimExecution.from_algorithm(algorithm)
    a = ex.add_local_slave(CosimLocalSlave(fmu_path=str(masses["MassA"]), instance_name="A"))
    b = ex.add_local_slave(CosimLocalSlave(fmu_path=str(masses["MassBBond"]), instance_name="B"))
    vr = {(name, v.name.decode()): v.reference for i, name in ((a, "A"), (b, "B")) for v in ex.slave_variables(i)}
    ex.real_initial_value(a, vr["A", "x0"], 1.0)
    ex.connect_real_variables(a, vr["A", "x"], b, vr["B", "x_in"])
    ex.connect_real_variables(b, vr["B", "F"], a, vr["A", "F"])
    ex.connect_real_variables(a, vr["A", "v"], b, vr["B", "v_in"])
    assert algorithm.add_power_bond(a, vr["A", "v"], vr["A", "F"], b, vr["B", "F"], vr["B", "v_in"]) == 0
    last = CosimObserver.create_last_value()
    ex.add_observer(last)
    rows = []
    while not rows or rows[-1][0] < stop - 1e-9:
        assert ex.step(1)
        rows.append([ex.status().current_time / 1e9,
                     *last.last_real_values(a, [vr["A", "v"], vr["A", "F"]]),
                     *last.last_real_values(b, [vr["B", "F"], vr["B", "v_in"]])])
    t, v1, force_held, force, v_in = np.array(rows).T
    return np.diff(np.concatenate([[0.0], t])), v1 * force_held, force * v_in


def test_ecco_takes_the_steps_libcosim_takes(tmp_path, masses):
    from master.algorithms.ecco import LIBCOSIM_GAINS
    from master.algorithms.step_control import PIController
    tol, h0, h_min, h_max, stop = 1e-3, 0.01, 1e-5, 0.1, 2.0
    h_lc, p_a, p_b = _libcosim_ecco(masses, stop, tol, h0, h_min, h_max)
    eps = np.abs((p_a - p_b) * h_lc) / (tol + tol * np.abs(np.maximum(p_a, p_b) * h_lc))
    # our controller law, fed libcosim's own powers and steps, predicts libcosim's next steps (from its third
    # step on: libcosim's second step grows by its maximum rate, 1.5, where the law gives 1.26)
    law = PIController(**{k: v for k, v in LIBCOSIM_GAINS.items()}, h_min=h_min, h_max=h_max, keep_on_zero=True,
                       r_prev=eps[1])
    predicted = [law.accepted(h, e) for h, e in zip(h_lc[2:30], eps[2:30])]
    np.testing.assert_allclose(predicted[:-1], h_lc[3:30], rtol=5e-3)
    # the whole run: the same number of steps, the same mean step, the residual held at the same level
    r = master.run(_bonded(tmp_path, masses, stop, stop), output=tmp_path / "out", algorithm="ecco", step_rtol=tol,
                   step_atol=tol, initial_step=h0, min_step=h_min, max_step=h_max)
    ours = pd.read_csv(tmp_path / "out" / "steps.csv")
    assert abs(len(ours) - len(h_lc)) <= 2
    assert abs(ours["step"].mean() / h_lc.mean() - 1) < 0.01
    for e in (eps, ours["error_estimate"].to_numpy()):
        assert abs(np.median(e[5:]) - EPS_STEADY) < 0.05


def test_ecco_needs_power_bonds_and_checks_them(tmp_path, masses):
    with pytest.raises(master.CosimError) as e:
        _ecco(_bonded(tmp_path, masses, 0.5, 1.0, name="none", bonds=()), None, 1e-3)
    assert "ecco needs power bonds, and the SSD declares none" in str(e.value) and "\n" not in str(e.value)
    wrong = ("spring", ("B", "F", "A", "F"), ("A", "x", "B", "v_in"))
    with pytest.raises(master.CosimError) as e:
        _ecco(_bonded(tmp_path, masses, 0.5, 1.0, name="wrong", bonds=(wrong,)), None, 1e-3)
    msg = str(e.value)
    assert "wrong.ssp" in msg and "PowerBond spring" in msg and "A.x -> B.v_in is not a connection" in msg
    with pytest.raises(master.CosimError, match="--error-estimate does not apply to ecco"):
        _ecco(_bonded(tmp_path, masses, 0.5, 1.0, name="est"), None, 1e-3, error_estimate="doubling")
    with pytest.raises(master.CosimError, match="--min-step: the minimum step 0.2 s is larger than the maximum"):
        _ecco(_bonded(tmp_path, masses, 0.5, 1.0, name="minmax"), None, 1e-3, min_step=0.2, max_step=0.1)


def test_a_study_of_ecco_draws_its_energy_residual(tmp_path, masses):
    # the study reads the energy residual ECCO logs per step (steps.csv) into its energy-residual figure
    import json
    from master.study.study import run_study
    ssp = _bonded(tmp_path, masses, 0.1, 2.0)
    out = tmp_path / "study"
    s = run_study(ssp, algorithms=["ecco"], extrapolations=[0], steps=[0.1], reference="fine:0.01",
                  record=["A.x", "B.x"], output=out, workers=1, progress=False)
    assert s.failed == 0 and (out / "energy_residual.png") in s.figures
    run_dir = next(p for p in (out / "runs").iterdir() if (p / "steps.csv").is_file())
    steps = pd.read_csv(run_dir / "steps.csv")
    meta = json.loads((run_dir / "run.json").read_text())
    assert steps["spring.energy_residual"].iloc[-1] == pytest.approx(meta["algorithm_info"]["energy_residual"]["spring"],
                                                                     rel=1e-12)
    # its work is counted like every algorithm's: two DoStep calls per accepted step (ECCO never rejects)
    assert meta["fmu_calls"]["do_step_total"] == meta["algorithm_info"]["fmu_calls"] == 2 * len(steps)
