"""The study's grid and table (issue 28): steps of any size through the campaign file, algorithm settings as
axes, variable-step algorithms swept over a tolerance without meaningless orders, diverged runs flagged without
an order, no order at round-off, iteration and rejected-step counts. Expectations: the closed forms of
ssp/coupling/oscillator_exact.py, the orders docs/coupling.md derives, and each run's own run.json."""
import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from master import yamlio
from master.cli import main
from master.study import run_study
from master.study.compare import ROUNDOFF, add_observed_orders
from master.study.study import campaign_text

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
EXACT = COUPLING / "oscillator_exact.py"


def _table(folder) -> list[dict]:
    with open(Path(folder) / "study.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def test_campaign_file_numbers_read_back_as_the_same_numbers():
    # YAML 1.1 reads 5e-05 (JSON's spelling) as a string; every magnitude must come back as the same float
    values = [m * 10.0 ** e for e in range(-300, 301, 7) for m in (1.0, 1.5, 2.5, 5.0, 9.99)]
    values += [5e-05, 1e-4, 2.5e-5, 1e16, 1e-5, 0.1, 3.0, 0.0, 1e-320, 123456789.0]
    values += [-v for v in values]
    data = {"runs": [{"algorithm": "jacobi", "step": v, "extrapolation": 1} for v in values],
            "run": {"stop_time": 5e-05}, "name": "study"}
    back = yamlio.load(campaign_text(data))
    assert back == data
    assert all(isinstance(r["step"], float) and r["step"] == v for r, v in zip(back["runs"], values))


def test_steps_below_1e_4_run(tmp_path):
    # the stiff oscillator's fast mode needs such steps; the study and a fine reference at 5e-5 must run them
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi"], extrapolations=[1], steps=[1e-4, 5e-5],
                  reference="fine:5e-5", record=["A.x"], output=out, workers=1, progress=False, stop_time=0.01)
    rows = _table(out)
    assert s.failed == 0 and [r["step"] for r in rows] == ["0.0001", "5e-05"]
    assert all(r["outcome"] == "completed" and math.isfinite(float(r["error_max"])) for r in rows)


def test_algorithm_settings_are_axes_for_the_algorithms_that_read_them(tmp_path, capsys):
    # Gauss-Seidel with linear extrapolation: order 1 with inputs held as computed, 2 with them interpolated
    # (docs/coupling.md); --gs-interpolation applies to gauss-seidel (and iterative), not to jacobi
    out = tmp_path / "s"
    assert main(["study", str(COUPLING / "oscillator_fd.ssp"), "--algorithm", "gauss-seidel", "jacobi",
                 "--extrapolation", "1", "--gs-interpolation", "0", "1", "--step", "0.04", "0.02", "0.01",
                 "--reference", f"analytic:{EXACT}:fd", "--record", "A.x", "-o", str(out), "--no-progress",
                 "--workers", "1"]) == 0
    with open(out / "study.csv", newline="") as fh:
        header = next(csv.reader(fh))
    assert header[:5] == ["algorithm", "extrapolation", "step", "gs_interpolation", "signal"]
    rows = _table(out)
    assert len(rows) == 9      # gauss-seidel x 2 settings x 3 steps + jacobi x 3 steps
    assert {r["gs_interpolation"] for r in rows if r["algorithm"] == "jacobi"} == {""}

    def orders(m):
        return [float(r["observed_order"]) for r in rows
                if r["algorithm"] == "gauss-seidel" and r["gs_interpolation"] == m and r["observed_order"]]
    assert len(orders("0")) == len(orders("1")) == 2
    assert np.all(np.abs(np.array(orders("0")) - 1.0) < 0.15), orders("0")
    assert np.all(np.abs(np.array(orders("1")) - 2.0) < 0.15), orders("1")
    assert "error_vs_step.png" in capsys.readouterr().out


def test_adaptive_is_swept_over_its_tolerance_without_orders_against_the_step(tmp_path):
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["adaptive"], extrapolations=[1], steps=[0.1],
                  reference=f"analytic:{EXACT}:fd", record=["A.x"], output=out, workers=1, progress=False,
                  settings={"step_rtol": [1e-3, 1e-4, 1e-5]}, stop_time=5.0)
    rows = sorted(_table(out), key=lambda r: -float(r["step_rtol"]))
    assert [float(r["step_rtol"]) for r in rows] == [1e-3, 1e-4, 1e-5]
    errors = [float(r["error_max"]) for r in rows]
    assert errors[0] > errors[1] > errors[2]
    assert all(r["observed_order"] == "" for r in rows)
    # the counts come from each run's run.json
    for r in rows:
        run = next(p for p in (out / "runs").iterdir() if p.is_dir() and float(r["step_rtol"])
                   == json.loads((p / "run.json").read_text())["algorithm_options"]["step_rtol"])
        info = json.loads((run / "run.json").read_text())["algorithm_info"]
        assert int(r["steps"]) == info["steps"] and int(r["rejected"]) == info["rejected"]
    assert int(rows[2]["steps"]) > int(rows[0]["steps"])
    assert any(p.name == "error_vs_tolerance.png" for p in s.figures)


def test_diverged_runs_are_flagged_without_an_order_and_iterations_are_counted(tmp_path):
    # the stiff oscillator: Jacobi (held) and iterative (end-of-step inputs) grow like 1.1^500 at h = 0.02
    # (docs/coupling.md: A.x off by 9e30 and 4e21); iterative with interpolated inputs stays bounded
    out = tmp_path / "s"
    s = run_study(COUPLING / "oscillator_stiff.ssp", algorithms=["jacobi", "iterative"], extrapolations=[0],
                  steps=[0.02, 0.01], reference=f"analytic:{EXACT}:stiff", record=["A.x", "B.x"], output=out,
                  workers=1, progress=False, settings={"coupling_interpolation": [0, 1]})
    rows = _table(out)
    flagged = {(r["algorithm"], r["coupling_interpolation"], r["step"]) for r in rows if r["outcome"] == "diverged"}
    assert ("jacobi", "", "0.02") in flagged and ("iterative", "0", "0.02") in flagged
    assert not any(i == "1" for _, i, _ in flagged)
    assert s.diverged == len(flagged) and f"{len(flagged)} diverged" in s.describe()
    assert all(r["observed_order"] == "" for r in rows if r["outcome"] == "diverged")
    for r in rows:
        if r["algorithm"] == "iterative":
            assert int(r["iterations"]) >= 2 * int(r["steps"]) and int(r["steps"]) == round(10 / float(r["step"]))
            if r["coupling_interpolation"] == "1":
                assert float(r["error_max"]) < 2.0          # bounded by the motion's own scale
        else:
            assert r["iterations"] == "" and r["rejected"] == ""


def _row(step, error, scale=1.0):
    return {"algorithm": "jacobi", "extrapolation": 0, "step": step, "signal": "y", "error_max": error,
            "reference_magnitude": scale, "outcome": "completed"}


def test_no_order_from_errors_at_round_off():
    rows = [_row(0.04, 4e-3), _row(0.02, 1e-3), _row(0.01, 0.5 * ROUNDOFF), _row(0.005, 0.2 * ROUNDOFF)]
    add_observed_orders(rows, [], set())
    assert rows[1]["observed_order"] == pytest.approx(2.0)
    assert all(math.isnan(r["observed_order"]) for r in (rows[0], rows[2], rows[3]))
    # the rule is relative to the signal's scale: the same errors on a signal of size 1e-6 are real errors
    rows = [_row(0.02, 4e-13, 1e-6), _row(0.01, 1e-13, 1e-6)]
    add_observed_orders(rows, [], set())
    assert rows[1]["observed_order"] == pytest.approx(2.0)       # a row's order: from its step to the next larger
