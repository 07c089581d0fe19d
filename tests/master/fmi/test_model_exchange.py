"""Model exchange, FMI 2.0 and 3.0: the Reference FMUs against their reference results (``ref/*_out.csv``) and
against fmpy, and the solvers (CVode BDF and Adams, forward Euler) against closed forms of Dahlquist's
x' = -k x. Every expectation is computed here, independently of the master."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from cli_in_process import run_cli
from master.errors import CosimError
from master.ssp.writer import SspBuilder

# Model -> the end of the interval compared with the reference results. The references are the co-simulation
# results of the same FMUs: forward Euler at the DefaultExperiment step. Model exchange integrates with CVode
# (nearly exact), so where the two solutions part by more than the band the comparison stops, the same for
# fmpy's own model exchange (checked in the test): BouncingBall's Euler bounces drift from the exact ones and
# from 1.53 s a sample falls between them (v jumps); VanDerPol drifts out of phase, past the band after ~15 s.
# Stair's last reference row (t = 9) is the count after the event that terminates the simulation, fmpy's
# the count before it: compared until just before (the whole of it, exactly, in the Stair test below).
COMPARED_UNTIL = {"BouncingBall": 1.5, "Dahlquist": None, "Feedthrough": None, "Resource": None, "Stair": 8.9,
                  "StateSpace": None, "VanDerPol": 10.0}
# Feedthrough: the outputs a connector can carry (Binary cannot be connected), each of a different kind
FEEDTHROUGH_OUTPUTS = (("Float64_continuous_output", "Real"), ("Float64_discrete_output", "Real"),
                       ("Int32_output", "Integer"), ("Boolean_output", "Boolean"))


def _as_matrix(values) -> np.ndarray:
    """A result column as floats, one column per element: booleans as 0/1, FMI 3.0 arrays ("1 2 3") split."""
    first = str(values[0]).strip().lower()
    if first in ("true", "false"):
        return np.array([[str(v).strip().lower() == "true"] for v in values], dtype=float)
    if " " in first:
        return np.array([[float(x) for x in str(v).split()] for v in values])
    return np.asarray(values, dtype=float).reshape(len(values), -1)


def _ours(df: pd.DataFrame, name: str) -> np.ndarray:
    """The master's columns of variable ``name`` (an array's elements are columns name[1], name[2], ...)."""
    if f"m.{name}" in df:
        return _as_matrix(df[f"m.{name}"].to_numpy())
    elements = [c for c in df.columns if c.startswith(f"m.{name}[")]
    return np.column_stack([_as_matrix(df[c].to_numpy())[:, 0] for c in elements])


def _within_crosscheck_band(times, got: np.ndarray, ref_times, ref: np.ndarray, what: str) -> None:
    """The FMI cross-check rule: within 10 % of each signal's range, compared at the reference's time points."""
    for j in range(ref.shape[1]):
        at_ref = np.interp(ref_times, times, got[:, j])
        band = 0.1 * (ref[:, j].max() - ref[:, j].min())
        assert np.max(np.abs(at_ref - ref[:, j])) <= band, f"{what}[{j}]"


def _single(tmp_path, fmu: Path, stop: float, step: float, connectors=None, **params) -> Path:
    b = SspBuilder("m", stop=stop, step=step)
    b.add_component("m", fmu, connectors=connectors, params=params or None)
    return b.write(tmp_path / "m.ssp")


def _run_me(ssp: Path, out: Path, **options):
    """The scenario with component m as model exchange: (run.json, results)."""
    master.run(ssp, output=out, record=["*"], implementation={"m": "ModelExchange"}, **options)
    return json.loads((out / "run.json").read_text()), pd.read_csv(out / "results.csv")


def _solver_stats(ssp: Path, out: Path, **options) -> dict:
    """run.json's statistics of component m's solver, run as model exchange."""
    return _run_me(ssp, out, **options)[0]["solvers"]["m"]


def _fmpy_me(fmu: Path, step: float):
    """fmpy's own model-exchange run of the FMU from its DefaultExperiment (its results on a grid of ``step``)."""
    import fmpy
    return fmpy.simulate_fmu(str(fmu), fmi_type="ModelExchange", output_interval=step)


# -- 1. every Reference FMU fmpy runs as model exchange runs so here, within the cross-check band -----------
@pytest.mark.parametrize("version", ["fmi3", "fmi2"])
@pytest.mark.parametrize("model", sorted(COMPARED_UNTIL))
def test_reference_fmu_as_model_exchange_within_the_crosscheck_band(tmp_path, reference_fmus, version, model):
    import fmpy
    fmu = reference_fmus / version / f"{model}.fmu"
    if not fmu.exists():
        pytest.skip(f"no {version} {model}")
    ref = pd.read_csv(reference_fmus / "ref" / f"{model}_out.csv")
    until = COMPARED_UNTIL[model]
    if until is not None:
        ref = ref[ref["time"] <= until + 1e-9]
    experiment = fmpy.read_model_description(str(fmu)).defaultExperiment
    stop = float(experiment.stopTime)
    step = float(experiment.stepSize) if experiment.stepSize else float(ref["time"].iloc[1] - ref["time"].iloc[0])
    compared = [c for c in ref.columns[1:] if model != "Feedthrough" or c in dict(FEEDTHROUGH_OUTPUTS)]

    theirs = _fmpy_me(fmu, step)
    connectors = ([(n, "output", t, None) for n, t in FEEDTHROUGH_OUTPUTS] if model == "Feedthrough" else None)
    meta, df = _run_me(_single(tmp_path, fmu, stop, step, connectors), tmp_path / "out")

    assert meta["outcome"] == "completed" and meta["fmus"]["m"]["kind"] == "ModelExchange"
    assert meta["solvers"]["m"]["solver"] == "cvode-bdf" and meta["solvers"]["m"]["steps"] > 0
    for col in compared:
        expected = _as_matrix(ref[col].to_numpy())
        # fmpy's model exchange agrees with the Euler reference over the interval: a fair interval
        _within_crosscheck_band(theirs["time"], theirs[col].reshape(len(theirs), -1).astype(float),
                                ref["time"], expected, f"fmpy {col}")
        _within_crosscheck_band(df["time"].to_numpy(), _ours(df, col), ref["time"], expected, col)


def test_fmi3_stair_ends_the_run_where_it_asks_to_terminate(tmp_path, reference_fmus):
    # Stair counts the seconds and sets terminateSimulation when the counter reaches 10 (at t = 9), at a time
    # event: the reference results end there, every count on time
    ref = pd.read_csv(reference_fmus / "ref" / "Stair_out.csv")
    meta, df = _run_me(_single(tmp_path, reference_fmus / "fmi3" / "Stair.fmu", 10.0, 0.2), tmp_path / "out")
    assert meta["outcome"] == "completed" and "error" not in meta
    assert meta["ended_early"] == {"time": pytest.approx(9.0),
                                   "reason": "component m asked to terminate the simulation"}
    np.testing.assert_allclose(df["time"], ref["time"], atol=1e-9)
    assert list(df["m.counter"]) == list(ref["counter"])
    assert meta["solvers"]["m"]["time_events"] == 9             # counter 1 -> 10, one time event per second


def test_fmi3_discrete_inputs_are_set_in_event_mode(tmp_path, reference_fmus, test_fmus):
    # a counter drives FMI 3.0 Feedthrough's Int32 input (Gauss-Seidel, source first): after k steps the counter
    # is k and Feedthrough passes it on in the same step, through an event at the start of each step
    b = SspBuilder("ft", stop=1.5, step=0.1, algorithm="gauss-seidel")
    b.add_component("src", test_fmus["py:Types"])
    b.add_component("m", reference_fmus / "fmi3" / "Feedthrough.fmu",
                    connectors=[("Int32_input", "input", "Integer", None), ("Int32_output", "output", "Integer", None)])
    b.connect("src", "counter", "m", "Int32_input")
    meta, df = _run_me(b.write(tmp_path / "ft.ssp"), tmp_path / "out")
    assert meta["outcome"] == "completed"
    assert list(df["m.Int32_output"]) == list(range(16))
    assert meta["solvers"]["m"]["input_events"] == 15            # the counter changes at every step
    assert "illegal call sequence" not in (tmp_path / "out" / "fmu.log").read_text().lower()


def test_fmi3_bouncing_ball_finds_its_one_bounce_in_the_first_second(tmp_path, reference_fmus):
    # h0 = 1, g = 9.81, e = 0.7: the ball lands at sqrt(2/g) = 0.4515 s and, rising at 0.7 sqrt(2 g), again
    # at 0.4515 + 2 * 0.7 * sqrt(2/g) = 1.084 s: one state event in [0, 1]
    meta, df = _run_me(_single(tmp_path, reference_fmus / "fmi3" / "BouncingBall.fmu", 1.0, 0.01), tmp_path / "o")
    assert meta["solvers"]["m"]["state_events"] == 1
    t_bounce = np.sqrt(2 / 9.81)
    after = df["time"] >= t_bounce + 0.01
    v_expected = 0.7 * 9.81 * t_bounce - 9.81 * (df["time"][after] - t_bounce)
    np.testing.assert_allclose(df["m.v"][after], v_expected, atol=1e-6)


# -- 2. solvers and tolerance: Dahlquist x' = -k x, x(0) = 1 ------------------------------------------------
K = 0.7


def _dahlquist(tmp_path, reference_fmus, version="fmi3") -> Path:
    """5 s in communication steps of 0.5."""
    return _single(tmp_path, reference_fmus / version / "Dahlquist.fmu", 5.0, 0.5, k=K)


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_euler_is_the_forward_euler_recurrence_at_the_internal_step(tmp_path, version, reference_fmus):
    h = 0.125                                   # 4 internal steps per communication step of 0.5
    meta, df = _run_me(_dahlquist(tmp_path, reference_fmus, version), tmp_path / "out", solver="euler", solver_step=h)
    x, expected = 1.0, [1.0]
    for n in range(1, 41):
        x = x + h * (-K * x)
        if n % 4 == 0:
            expected.append(x)
    assert df["m.x"].tolist() == expected                       # bit for bit
    np.testing.assert_allclose(df["m.x"], (1 - K * h) ** (4 * np.arange(11)), rtol=1e-13)
    stats = meta["solvers"]["m"]
    assert stats["solver"] == "euler" and stats["internal_step"] == h
    assert stats["steps"] == 40 and stats["rhs_evaluations"] == 40 and stats["events"] == 0


def test_euler_at_the_communication_step_is_the_co_simulation_reference(tmp_path, reference_fmus):
    # the Reference FMU's own co-simulation is forward Euler at 0.1 with k = 1: Dahlquist_out.csv is 0.9**n
    ref = pd.read_csv(reference_fmus / "ref" / "Dahlquist_out.csv")
    ssp = _single(tmp_path, reference_fmus / "fmi3" / "Dahlquist.fmu", 10.0, 0.1)
    meta, df = _run_me(ssp, tmp_path / "out", solver="euler")
    np.testing.assert_allclose(df["m.x"], ref["x"], rtol=1e-12)
    assert meta["solvers"]["m"]["steps"] == 100


@pytest.mark.parametrize("solver", ["cvode-bdf", "cvode-adams"])
def test_cvode_matches_the_exponential_within_its_tolerance(tmp_path, solver, reference_fmus):
    errors = {}
    for rtol in (1e-5, 1e-9):
        meta, df = _run_me(_dahlquist(tmp_path, reference_fmus), tmp_path / f"out{rtol}", solver=solver, tolerance=rtol)
        exact = np.exp(-K * df["time"].to_numpy())
        errors[rtol] = np.max(np.abs(df["m.x"].to_numpy() - exact))
        # CVode controls the local error against rtol |x| + atol (atol = rtol x the state's nominal, 1); the
        # global error over 5 s (10 restarts at the communication points) stays within a small multiple
        assert errors[rtol] <= 50 * rtol, (rtol, errors[rtol])
        stats = meta["solvers"]["m"]
        assert stats["solver"] == solver and stats["relative_tolerance"] == rtol
        assert stats["steps"] > 0 and stats["rhs_evaluations"] >= stats["steps"] and stats["events"] == 0
    assert errors[1e-9] < errors[1e-5] / 100                    # the tolerance reaches the solver


def test_adams_takes_fewer_steps_than_bdf_on_a_smooth_problem(tmp_path, reference_fmus):
    # Adams goes up to order 12, BDF to order 5: at a tight tolerance on a smooth non-stiff problem, Adams
    # needs clearly fewer steps (that the method really changed, which the results alone hardly show)
    ssp = _dahlquist(tmp_path, reference_fmus)
    steps = {s: _solver_stats(ssp, tmp_path / s, solver=s, tolerance=1e-10)["steps"]
             for s in ("cvode-bdf", "cvode-adams")}
    assert steps["cvode-adams"] < 0.75 * steps["cvode-bdf"], steps


def test_tolerance_from_the_command_line_else_the_default_experiment_else_1e_10(tmp_path, reference_fmus):
    roberts = _single(tmp_path, reference_fmus / "fmi3" / "Roberts.fmu", 1.0, 0.1)    # DefaultExperiment 1e-4
    assert _solver_stats(roberts, tmp_path / "a")["relative_tolerance"] == 1e-4
    assert _solver_stats(roberts, tmp_path / "b", tolerance=1e-6)["relative_tolerance"] == 1e-6
    assert _solver_stats(_dahlquist(tmp_path, reference_fmus), tmp_path / "c")["relative_tolerance"] == 1e-10


def test_co_simulation_runs_have_no_solver_statistics(tmp_path, reference_fmus):
    ssp = _single(tmp_path, reference_fmus / "fmi3" / "Dahlquist.fmu", 1.0, 0.1)
    meta = master.run(ssp, output=tmp_path / "out").metadata
    assert meta["fmus"]["m"]["kind"] == "CoSimulation" and "solvers" not in meta


@pytest.mark.parametrize("options,message", [
    ({"solver": "rk4"}, "--solver: unknown solver 'rk4'"),
    ({"solver": "euler", "solver_step": 0.0}, "--solver-step: must be positive"),
    ({"solver": "cvode-bdf", "solver_step": 0.1}, "--solver-step: an internal step is for the fixed-step solver"),
])
def test_solver_options_are_checked_before_the_run(tmp_path, options, message, reference_fmus):
    with pytest.raises(CosimError, match=message):
        master.run(_dahlquist(tmp_path, reference_fmus), output=None, implementation={"m": "ModelExchange"}, **options)


def test_the_command_line_chooses_the_solver(tmp_path, reference_fmus):
    out = tmp_path / "out"
    ssp = _dahlquist(tmp_path, reference_fmus)
    r = run_cli(["run", str(ssp), "-o", str(out), "--implementation", "m=me", "--solver", "euler",
                 "--solver-step", "0.25"])
    assert r.returncode == 0, r.stderr
    stats = json.loads((out / "run.json").read_text())["solvers"]["m"]     # the supervised run's run.json
    assert (stats["solver"], stats["internal_step"], stats["steps"]) == ("euler", 0.25, 20)
