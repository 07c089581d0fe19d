"""Per-output extrapolation orders and Gauss-Seidel interpolation of known inputs, on the two-mass oscillator
(C FMUs MassA/MassB) against its closed form. docs/coupling.md derives the expected orders."""
import json

import numpy as np
import pandas as pd
import pytest

import master
from cli_in_process import run_cli
from master.algorithms.gs_interpolation import interpolation_weights
from master.ssp.writer import SspBuilder

from analytic import two_mass_exact

STEPS = [0.04, 0.02, 0.01]       # h, h/2, h/4 over 10 s, as test_coupling.py


def _osc(tmp_path, fmus, h, orders=None, name="osc"):
    """A.x -> B.x_in, B.F -> A.F; ``orders``: the SSD's per-connection annotations, by source output."""
    orders = orders or {}
    b = SspBuilder(name, stop=10.0, step=h)
    b.add_component("A", fmus["MassA"], params={"x0": 1.0})
    b.add_component("B", fmus["MassB"])
    b.connect("A", "x", "B", "x_in", extrapolation=orders.get("A.x"))
    b.connect("B", "F", "A", "F", extrapolation=orders.get("B.F"))
    return b.write(tmp_path / f"{name}_{h}.ssp")


@pytest.fixture
def masses(test_fmus):
    return {m: test_fmus[f"c2:{m}"] for m in ("MassA", "MassB")}


def _error(df) -> float:
    x1, _, x2, _ = two_mass_exact(df["time"].to_numpy())
    return max(np.max(np.abs(df["A.x"] - x1)), np.max(np.abs(df["B.x"] - x2)))


def _orders(tmp_path, masses, **options):
    errors = [_error(master.run(_osc(tmp_path, masses, h), output=None, record=["A.x", "B.x"], **options).frame)
              for h in STEPS]
    return errors, np.log2(np.array(errors[:-1]) / np.array(errors[1:]))


def test_order_one_on_every_coupled_output_is_the_global_order_bit_for_bit(tmp_path, masses):
    ssp = _osc(tmp_path, masses, 0.02)
    for algorithm in ("jacobi", "gauss-seidel"):
        a = master.run(ssp, output=None, record=["*"], algorithm=algorithm, extrapolation=1).frame
        b = master.run(ssp, output=None, record=["*"], algorithm=algorithm,
                       extrapolation_for={"A.x": 1, "B.F": 1}).frame
        assert a.equals(b), algorithm


def test_one_held_output_makes_the_coupling_first_order(tmp_path, masses):
    # A.F held over the step misses the integral of F by F' h^2 / 2 per step (docs/coupling.md): a global
    # O(h) error whatever the other coupling does; with both extrapolated it is second order
    errors, slopes = _orders(tmp_path, masses, algorithm="jacobi", extrapolation_for={"A.x": 1, "B.F": 0})
    assert np.all(np.abs(slopes - 1.0) < 0.15), (errors, slopes)
    errors_x_held, slopes_x_held = _orders(tmp_path, masses, algorithm="jacobi", extrapolation_for={"A.x": 0,
                                                                                                   "B.F": 1})
    assert np.all(np.abs(slopes_x_held - 1.0) < 0.15), (errors_x_held, slopes_x_held)


def test_ssd_annotation_cli_and_api_give_the_same_run(tmp_path, masses):
    h = 0.05
    plain = _osc(tmp_path, masses, h)
    annotated = _osc(tmp_path, masses, h, orders={"A.x": 1, "B.F": 2}, name="annotated")
    api = master.run(plain, output=None, record=["*"], extrapolation_for={"A.x": 1, "B.F": 2})
    ssd = master.run(annotated, output=None, record=["*"])
    assert api.frame.equals(ssd.frame)
    assert ssd.metadata["algorithm_info"]["extrapolation"]["per_output"] == {"A.x": 1, "B.F": 2}
    assert ssd.metadata["settings_sources"]["extrapolation_for"]["A.x"] == "SSD Connection A.x -> B.x_in"
    # the caller's order replaces the SSD's for that output only
    mixed = master.run(annotated, output=None, record=["*"], extrapolation_for={"B.F": 0})
    assert mixed.metadata["algorithm_info"]["extrapolation"]["per_output"] == {"A.x": 1, "B.F": 0}
    out = tmp_path / "cli"
    r = run_cli(["run", str(plain), "--output", str(out), "--record", "*", "--extrapolate", "A.x=1", "--extrapolate",
                 "B.F=2", "--no-supervise"])
    assert r.returncode == 0, r.stderr
    cli = pd.read_parquet(out / "results.parquet")
    np.testing.assert_array_equal(cli[list(api.frame.columns)].to_numpy(), api.frame.to_numpy())
    run_json = json.loads((out / "run.json").read_text())
    assert run_json["algorithm_info"]["extrapolation"]["per_output"] == {"A.x": 1, "B.F": 2}


@pytest.mark.parametrize("options, message", [
    ({"extrapolation_for": {"A.nope": 1}}, r"--extrapolate A.nope: unknown variable 'A.nope'"),
    ({"extrapolation_for": {"A.v": 1}}, r"--extrapolate A.v: A.v is not a coupled Real output"),
    ({"extrapolation_for": {"B.x_in": 1}}, r"--extrapolate B.x_in: B.x_in is not a coupled Real output"),
    ({"extrapolation_for": {"A.x": 3}}, r"--extrapolate A.x: the order must be 0, 1 or 2, not 3"),
    ({"extrapolation_for": {"A.x": 1}, "algorithm": "iterative"}, r"do not apply to the iterative algorithm"),
    ({"extrapolation_for": {"A.x": 1}, "algorithm": "adaptive"}, r"adaptive takes the global --extrapolation"),
    ({"gs_interpolation": 1, "algorithm": "jacobi"}, r"--gs-interpolation: applies to gauss-seidel only, not to jacobi"),
    ({"gs_interpolation": 3, "algorithm": "gauss-seidel"}, r"--gs-interpolation: must be one of 0, 1, 2"),
])
def test_bad_per_output_settings_are_one_line_errors(tmp_path, masses, options, message):
    with pytest.raises(master.CosimError, match=message) as e:
        master.run(_osc(tmp_path, masses, 0.1), output=None, **options)
    assert "\n" not in str(e.value)


def test_bad_order_on_the_command_line_is_one_line(tmp_path, masses):
    p = run_cli(["run", str(_osc(tmp_path, masses, 0.1)), "--output", str(tmp_path / "out"), "--extrapolate",
                 "A.x=one"])
    assert p.returncode != 0 and "Traceback" not in p.stderr
    assert p.stderr.strip() == "cosim-master: error: --extrapolate A.x: the order must be 0, 1 or 2, got 'one'"


def test_bad_ssd_annotations_name_the_connection(tmp_path, masses):
    b = SspBuilder("bad", stop=1.0, step=0.1)
    b.add_component("A", masses["MassA"])
    b.add_component("B", masses["MassB"])
    b.connect("A", "x", "B", "x_in", extrapolation=1)
    b.connect("B", "F", "A", "F")
    folder = b.write(tmp_path / "bad")
    ssd = folder / "SystemStructure.ssd"
    ssd.write_text(ssd.read_text().replace('order="1"', 'order="5"'))
    with pytest.raises(master.CosimError, match=r"Connection A.x -> B.x_in.*order must be 0, 1 or 2, got '5'"):
        master.run(folder, output=None)
    # two connections from one output asking for different orders
    b.connections[1] = ("A", "x", "A", "F", None, None, False, 2)
    with pytest.raises(master.CosimError, match=r"from A.x ask for extrapolation orders 1 and 2"):
        master.run(b.write(tmp_path / "bad2.ssp"), output=None)


def test_interpolation_weights_are_the_trapezoid_and_adams_moulton_weights():
    assert interpolation_weights(1) == (1.0,)
    np.testing.assert_allclose(interpolation_weights(2), [0.5, 0.5], rtol=1e-14)
    np.testing.assert_allclose(interpolation_weights(3), [5 / 12, 8 / 12, -1 / 12], rtol=1e-14)


@pytest.mark.parametrize("interpolation, extrapolation, order", [(0, 1, 1.0), (1, 1, 2.0), (2, 1, 2.0)])
def test_gauss_seidel_interpolation_order(tmp_path, masses, interpolation, extrapolation, order):
    # sweep A then B: A reads B.F from the previous step (extrapolated, K = 1), B reads A.x of the step's end;
    # held as computed that is half a step ahead (order 1), its mean over the step makes it order 2
    errors, slopes = _orders(tmp_path, masses, algorithm="gauss-seidel", extrapolation=extrapolation,
                             gs_interpolation=interpolation)
    assert np.all(np.abs(slopes - order) < 0.15), (errors, slopes)


def test_gauss_seidel_interpolation_is_recorded(tmp_path, masses):
    r = master.run(_osc(tmp_path, masses, 0.1), output=None, algorithm="gauss-seidel", extrapolation=1,
                   gs_interpolation=1)
    info = r.metadata["algorithm_info"]
    assert info["interpolation"]["interpolated"] == ["A.x"] and info["interpolation"]["weights"] == [0.5, 0.5]
    assert info["loops_broken_at"] == ["B.F -> A.F"]


def test_interpolating_sweep_with_nothing_to_interpolate_is_the_compiled_step(tmp_path, masses):
    # A on a step multiple: its outputs are staged and held, so no value is interpolated, and the sweep (a loop
    # over the bound operations, publishing at its end) must be the compiled Gauss-Seidel step bit for bit
    ssp = _osc(tmp_path, masses, 0.1)
    runs = [master.run(ssp, output=None, record=["*"], algorithm="gauss-seidel", extrapolation=1, stop_time=2.0,
                       step_multiples={"A": 2}, gs_interpolation=m) for m in (1, 0)]
    assert runs[0].metadata["algorithm_info"]["interpolation"]["interpolated"] == []
    assert runs[0].frame.equals(runs[1].frame)
