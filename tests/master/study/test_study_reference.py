"""The study's references (issue 28): a fine reference of second order whose own error is estimated by halving
its step and written into study.csv, a warning where that error is not well below what it measures, and a
failed reference that still leaves the grid's table. Expectations come from the closed form of the two-mass
oscillator (ssp/coupling/oscillator_exact.py, checked against tests/analytic.py in test_study.py)."""
import csv
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import master
from coupling_refs import coupling_reference
from master.ssp.writer import SspBuilder
from master.study import run_study

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
EXACT = COUPLING / "oscillator_exact.py"


def _exact():
    return coupling_reference("oscillator_exact")


def _table(folder) -> list[dict]:
    with open(Path(folder) / "study.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _orders(rows, k) -> list[float]:
    return [float(r["observed_order"]) for r in rows if r["extrapolation"] == str(k) and r["observed_order"]]


STOP = 5.0      # the first half of the SSP's 10 s: the same order and reference-error checks hold on half the steps


def test_fine_reference_measures_orders_one_and_two_and_states_its_own_error(tmp_path):
    # Jacobi held (order 1) and linearly extrapolated (order 2) against fine:0.002, a second-order reference at
    # 0.001 whose estimated error (from the run at 0.002, Richardson) must be its true error against the closed
    # form; with the old first-order iterative reference at this step the orders came out near 0
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi"], extrapolations=[0, 1],
                  steps=[0.04, 0.02, 0.01], reference="fine:0.002", record=["A.x", "B.x"], output=out, workers=1,
                  progress=False, stop_time=STOP)
    rows = _table(out)
    assert s.failed == 0 and not s.warnings and len(rows) == 12
    assert np.all(np.abs(np.array(_orders(rows, 0)) - 1.0) < 0.15), _orders(rows, 0)
    assert np.all(np.abs(np.array(_orders(rows, 1)) - 2.0) < 0.15), _orders(rows, 1)
    # the reference run at H / 2 against the closed form: its true error, which the table must estimate
    fine = [p for p in (out / "runs").iterdir()
            if p.is_dir() and json.loads((p / "run.json").read_text())["step_size"] == 0.001]
    assert len(fine) == 1
    meta = json.loads((fine[0] / "run.json").read_text())
    assert meta["algorithm"] == "iterative" and meta["algorithm_options"]["coupling_interpolation"] == 1
    df = pd.read_parquet(fine[0] / "results.parquet")
    truth = _exact().fd(df["time"].to_numpy())
    for r in rows:
        true_error = np.max(np.abs(df[r["signal"]].to_numpy() - truth[r["signal"]]))
        assert float(r["reference_error"]) == pytest.approx(true_error, rel=0.05)
        assert float(r["reference_error"]) < 0.01 * float(r["error_max"])
        assert r["reference"].startswith("fine:0.002: iterative, trapezoidal inputs (order 2) at 0.001 s")


def test_a_reference_not_far_below_the_errors_it_measures_is_warned_about(tmp_path):
    # fine:0.02 is second order at 0.01 (error ~1e-4), as large as Jacobi K = 1's error at 0.01 (~2e-4)
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi"], extrapolations=[1], steps=[0.02, 0.01],
                  reference="fine:0.02", record=["A.x"], output=out, workers=1, progress=False)
    assert len(s.warnings) == 1 and "A.x" in s.warnings[0] and "fine:0.02" in s.warnings[0]
    assert "warning: the reference's own error of A.x" in s.describe()
    rows = _table(out)
    assert all(float(r["reference_error"]) > 0.1 * float(r["error_max"]) for r in rows if r["step"] == "0.01")


def test_analytic_reference_is_named_with_zero_error(tmp_path):
    out = tmp_path / "s"
    run_study(COUPLING / "algebraic_loop.ssp", algorithms=["jacobi"], extrapolations=[0], steps=[0.2, 0.1],
              reference=f"analytic:{EXACT}:loop", record=["L1.y"], output=out, workers=1, progress=False)
    rows = _table(out)
    assert all(r["reference"] == f"analytic:{EXACT}:loop (closed form)" and float(r["reference_error"]) == 0.0
               for r in rows)


def test_a_failed_reference_run_still_leaves_the_grids_table(tmp_path, test_fmus):
    # two Integrators that cannot save their state: the Jacobi grid runs, the fine reference (iterative, which
    # rolls back) cannot; study.csv keeps the grid's runs with empty errors and the reason
    b = SspBuilder("chain", stop=1.0, step=0.1)
    b.add_component("I1", test_fmus["c2:Integrator"], params={"a": -1.0, "x0": 1.0})
    b.add_component("I2", test_fmus["c2:Integrator"], params={"a": -0.5, "x0": 0.0})
    b.connect("I2", "y", "I1", "u")
    b.connect("I1", "y", "I2", "u")
    ssp = b.write(tmp_path / "chain.ssp")
    out = tmp_path / "s"
    with pytest.raises(master.CosimError) as err:
        run_study(ssp, algorithms=["jacobi"], extrapolations=[0], steps=[0.1, 0.05], reference="fine:0.01",
                  record=["I1.y", "I2.y"], output=out, workers=1, progress=False)
    msg = str(err.value)
    assert "\n" not in msg and "fine:0.01 has no results" in msg and "cannot save and restore" in msg
    assert "study.csv" in msg
    rows = _table(out)
    assert len(rows) == 4 and {r["signal"] for r in rows} == {"I1.y", "I2.y"}
    for r in rows:
        assert r["outcome"] == "completed" and int(r["fmu_calls"]) > 0
        assert r["error_max"] == r["error_rms"] == r["observed_order"] == r["reference_error"] == ""
        assert "cannot save and restore" in r["reference"]


def test_a_fine_reference_read_between_its_samples_adds_the_interpolation_bound():
    # samples of sin(5 t) every 0.01 s read at the midpoints: linear interpolation errs by up to
    # h^2/8 max |y''| = 25e-4/8 = 3.1e-4 there, which the reference's error must then include and bound (as
    # max |second difference| / 6: a third more, for |y''| peaking between samples)
    from master.study.reference import parse_reference
    ref = parse_reference("fine:0.02")
    t = np.arange(0.0, 1.0 + 1e-9, 0.01)
    coarse_t = t[::2]
    ref.set_fine(pd.DataFrame({"time": coarse_t, "y": np.sin(5 * coarse_t) + 3e-4}),
                 pd.DataFrame({"time": t, "y": np.sin(5 * t)}))
    assert ref.error("y") == pytest.approx(1e-4) and ref.error("y", coarse_t) == pytest.approx(1e-4)
    between = t[:-1] + 0.005
    interpolation = np.max(np.abs(ref.values(between, ["y"])["y"] - np.sin(5 * between)))
    assert 0.5 * 25e-4 / 8 < interpolation <= ref.error("y", between) - 1e-4 <= 25e-4 / 6 * 1.01
