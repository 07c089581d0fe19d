"""The study command and the coupling benchmarks of ssp/coupling, against closed forms derived here or in
tests/analytic.py (not against earlier output): observed orders of Jacobi with held and extrapolated inputs,
the algebraic loop's fixed point, the three kinds of reference, resuming, and one-line errors for bad
arguments; the algorithm settings from the SSD annotation and the campaign file."""
import csv
import json
from pathlib import Path

import numpy as np
import pytest

import master
from coupling_refs import coupling_reference
from master.cli import main
from master.results import read_results
from master.study import run_study
from master.ssp.writer import SspBuilder

from analytic import two_mass_exact

REPO = Path(__file__).resolve().parents[3]
COUPLING = REPO / "ssp" / "coupling"
EXACT = COUPLING / "oscillator_exact.py"
COLUMNS = ["algorithm", "extrapolation", "step", "signal", "error_max", "error_rms", "fmu_calls", "wall_s",
           "observed_order"]
# Jacobi on the oscillator, 0..10 s: order 1 held, 2 with K = 1 (docs/coupling.md derives both)
ORDER_STEPS = [0.04, 0.02, 0.01]


def _table(folder) -> list[dict]:
    with open(Path(folder) / "study.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _fixed_point(t, a1=0.5, b1=1.0, c1=0.5, w1=1.0, a2=-0.8, b2=2.0, c2=0.0, w2=1.0):
    """The loop y1 = a1 y2 + g1(t), y2 = a2 y1 + g2(t) solved as a linear system at every time (the
    parameters written in ssp/coupling/algebraic_loop.ssp)."""
    A = np.array([[1.0, -a1], [-a2, 1.0]])
    g = np.stack([b1 + c1 * np.sin(w1 * t), b2 + c2 * np.sin(w2 * t)])
    return np.linalg.solve(A, g)


def test_shipped_closed_form_is_the_modal_solution():
    ex = coupling_reference("oscillator_exact")
    t = np.linspace(0.0, 10.0, 301)
    got = ex.fd(t)
    x1, v1, x2, v2 = two_mass_exact(t)
    for name, want in (("A.x", x1), ("A.v", v1), ("B.x", x2), ("B.v", v2)):
        np.testing.assert_allclose(got[name], want, atol=1e-12)
    x1, _, x2, _ = two_mass_exact(t, kc=1000.0)
    np.testing.assert_allclose(ex.stiff(t)["A.x"], x1, atol=1e-12)
    np.testing.assert_allclose(ex.loop(t)["L1.y"], _fixed_point(t)[0], atol=1e-12)


def test_study_measures_order_one_held_and_two_extrapolated_and_resumes(tmp_path):
    out = tmp_path / "study"
    s = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi"], extrapolations=[0, 1], steps=ORDER_STEPS,
                  reference=f"analytic:{EXACT}:fd", record=["A.x", "B.x"], output=out, workers=1, progress=False)
    assert s.ran_now == 6 and s.failed == 0
    with open(out / "study.csv", newline="") as fh:
        assert next(csv.reader(fh))[:len(COLUMNS)] == COLUMNS
    rows = _table(out)
    assert len(rows) == 2 * 3 * 2            # runs x signals
    for r in rows:
        h, k = float(r["step"]), int(r["extrapolation"])
        assert int(r["fmu_calls"]) == 2 * round(10.0 / h)       # two FMUs, one DoStep each per step
        if h == max(ORDER_STEPS):
            assert r["observed_order"] == ""
        else:
            assert abs(float(r["observed_order"]) - (1.0 if k == 0 else 2.0)) < 0.15, r
    # the table's error is the distance to the modal solution computed here
    run_dirs = sorted(p for p in (out / "runs").iterdir() if p.is_dir())
    df = read_results(run_dirs[0])
    x1, _, x2, _ = two_mass_exact(df["time"].to_numpy())
    mine = {"A.x": np.max(np.abs(df["A.x"] - x1)), "B.x": np.max(np.abs(df["B.x"] - x2))}
    meta = json.loads((run_dirs[0] / "run.json").read_text())
    row = [r for r in rows if float(r["step"]) == meta["step_size"]
           and int(r["extrapolation"]) == meta["algorithm_options"]["extrapolation"]]
    for r in row:
        assert float(r["error_max"]) == pytest.approx(mine[r["signal"]], rel=1e-9)
    for name in ("error_vs_step.png", "work_precision.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    records = {p.name: p.read_text() for p in (out / "runs").glob("*.json")}

    again = run_study(COUPLING / "oscillator_fd.ssp", algorithms=["jacobi"], extrapolations=[0, 1],
                      steps=ORDER_STEPS, reference=f"analytic:{EXACT}:fd", record=["A.x", "B.x"], output=out,
                      workers=1, progress=False)
    assert again.ran_now == 0
    assert {p.name: p.read_text() for p in (out / "runs").glob("*.json")} == records
    assert _table(out) == rows


@pytest.mark.parametrize("ssp", ["algebraic_loop.ssp", "algebraic_loop_py.ssp"])
def test_iterative_coupling_meets_the_algebraic_loops_fixed_point(ssp):
    df = master.run(COUPLING / ssp, output=None, algorithm="iterative", coupling_tol=1e-12, record=["*.y"]).frame
    y1, y2 = _fixed_point(df["time"].to_numpy())
    np.testing.assert_allclose(df["L1.y"], y1, atol=1e-10)
    np.testing.assert_allclose(df["L2.y"], y2, atol=1e-10)


def test_fine_and_file_references_agree_with_the_closed_form(tmp_path):
    # on the algebraic loop the iterative run is exact at every step, so the fine reference (and its results
    # file) must give the closed form's errors; Jacobi lags one step behind the fixed point
    common = dict(algorithms=["jacobi"], extrapolations=[0], steps=[0.2, 0.1], record=["L1.y", "L2.y"],
                  workers=1, progress=False)
    ssp = COUPLING / "algebraic_loop.ssp"
    run_study(ssp, reference=f"analytic:{EXACT}:loop", output=tmp_path / "a", **common)
    run_study(ssp, reference="fine:0.01", output=tmp_path / "f", **common)
    fine_run = [p for p in (tmp_path / "f" / "runs").iterdir()
                if p.is_dir() and json.loads((p / "run.json").read_text())["step_size"] == 0.01]
    run_study(ssp, reference=str(fine_run[0] / "results.parquet"), output=tmp_path / "p", **common)
    a, f, p = (_table(tmp_path / d) for d in "afp")
    assert len(a) == len(f) == len(p) == 4
    for ra, rf, rp in zip(a, f, p):
        assert float(ra["error_max"]) > 1e-2          # a real error, which the references must agree on
        assert float(rf["error_max"]) == pytest.approx(float(ra["error_max"]), abs=1e-9)
        assert float(rp["error_max"]) == pytest.approx(float(ra["error_max"]), abs=1e-9)


@pytest.mark.parametrize("args, message", [
    (["--algorithm", "nope"], "--algorithm: unknown algorithm 'nope'"),
    (["--extrapolation", "3"], "--extrapolation: must be one of 0, 1, 2"),
    (["--step", "-0.1"], "--step: a step must be a positive number"),
    (["--reference", "exact"], "--reference: expected analytic:MODULE:FUNCTION, fine:H or a results file"),
    (["--reference", f"analytic:{EXACT}:nope"], "has no function 'nope'"),
    (["--reference", "fine:0"], "expected fine:H with a positive step"),
    (["--reference", "missing.parquet"], "results file not found"),
    (["--algorithm", "iterative", "--extrapolation", "1"], "no run left in the grid"),
])
def test_bad_study_arguments_give_one_line_errors(tmp_path, capsys, args, message):
    base = {"--algorithm": ["jacobi"], "--extrapolation": ["0"], "--step": ["0.1"],
            "--reference": [f"analytic:{EXACT}:fd"]}
    i = 0
    while i < len(args):
        flag = args[i]
        j = i + 1
        while j < len(args) and not args[j].startswith("--"):
            j += 1
        base[flag] = args[i + 1:j]
        i = j
    argv = ["study", str(COUPLING / "oscillator_fd.ssp"), "-o", str(tmp_path / "s"), "--no-progress"]
    for flag, values in base.items():
        argv += [flag, *values]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err
    assert not (tmp_path / "s" / "runs").exists()


# -- algorithm settings from the SSD and from a campaign --------------------------------------------------------
def _with_settings(tmp_path, **attrs) -> Path:
    """oscillator_fd.ssp's SSD with attributes added to our settings annotation."""
    import zipfile
    with zipfile.ZipFile(COUPLING / "oscillator_fd.ssp") as z:
        ssd = z.read("SystemStructure.ssd").decode()
        z.extractall(tmp_path / "osc")
    extra = " ".join(f'{k}="{v}"' for k, v in attrs.items())
    (tmp_path / "osc" / "SystemStructure.ssd").write_text(ssd.replace("<cm:Settings ", f"<cm:Settings {extra} ", 1))
    return tmp_path / "osc"


def test_algorithm_settings_from_the_ssd_annotation_with_their_source(tmp_path):
    ssp = _with_settings(tmp_path, extrapolation="1", couplingUpdate="aitken")
    meta = master.run(ssp, output=None, stop_time=0.1).metadata
    assert meta["algorithm_options"]["extrapolation"] == 1
    assert meta["settings_sources"]["extrapolation"] == "SSD settings annotation"
    assert meta["settings_sources"]["coupling_tol"] == "default"
    meta = master.run(ssp, output=None, stop_time=0.1, extrapolation=0).metadata
    assert meta["algorithm_options"]["extrapolation"] == 0
    assert meta["settings_sources"]["extrapolation"] == "command line"
    bad = _with_settings(tmp_path / "bad", couplingMaxIter="0")
    with pytest.raises(master.CosimError, match=r"Settings: couplingMaxIter: must be >= 1, got '0'"):
        master.run(bad, output=None)


def test_algorithm_settings_in_a_campaign_are_checked_and_recorded(tmp_path):
    from master.campaign.runner import run_campaign
    camp = tmp_path / "c.yaml"
    camp.write_text(f"name: c\nscenario: {COUPLING / 'oscillator_fd.ssp'}\nrun:\n  stop_time: 0.5\n"
                    "  algorithm: iterative\n  coupling_tol: 1.0e-8\ngrid:\n  coupling_update: [aitken, iqn-ils]\n")
    s = run_campaign(camp, output=tmp_path / "out", workers=1, progress=False)
    assert s.completed == 2
    metas = [json.loads(p.read_text()) for p in (tmp_path / "out" / "runs").glob("*/run.json")]
    assert sorted(m["algorithm_options"]["coupling_update"] for m in metas) == ["aitken", "iqn-ils"]
    assert all(m["algorithm_info"]["rtol"] == 1e-8 and m["settings_sources"]["coupling_tol"] == "campaign"
               for m in metas)
    camp.write_text(camp.read_text().replace("1.0e-8", "-1"))
    with pytest.raises(master.CosimError, match=r"run.coupling_tol: must be >= 0"):
        run_campaign(camp, output=tmp_path / "out2", workers=1, progress=False)


def test_settings_annotation_written_by_the_builder(tmp_path):
    b = SspBuilder("osc", stop=0.1, step=0.05, algorithm_options={"extrapolation": 2})
    b.add_component("A", COUPLING / "fmus" / "MassA.fmu").add_component("B", COUPLING / "fmus" / "MassB.fmu")
    b.connect("A", "x", "B", "x_in").connect("B", "F", "A", "F")
    meta = master.run(b.write(tmp_path / "o.ssp"), output=None).metadata
    assert meta["algorithm_options"]["extrapolation"] == 2
    assert meta["settings_sources"]["extrapolation"] == "SSD settings annotation"


def test_algorithm_settings_in_a_uav_scenario_yaml(tmp_path):
    from uavstudy.build import build_ssp
    from uavstudy.scenario import load_scenario_yaml
    text = (REPO / "ssp" / "scenarios" / "paper_area.yaml").read_text()
    good = tmp_path / "good.yaml"
    good.write_text(text + "\nalgorithm_options:\n  extrapolation: 1\n")
    meta = master.run(build_ssp(load_scenario_yaml(good), tmp_path / "good.ssp"), output=None,
                      stop_time=0.3).metadata
    assert meta["algorithm_options"]["extrapolation"] == 1
    assert meta["settings_sources"]["extrapolation"] == "SSD settings annotation"
    bad = tmp_path / "bad.yaml"
    bad.write_text(text + "\nalgorithm_options:\n  coupling_update: newton\n")
    with pytest.raises(master.CosimError, match=r"algorithm_options.coupling_update: must be one of fixed-point"):
        load_scenario_yaml(bad)


def test_shipped_benchmark_fmus_carry_the_current_sources():
    # a change to a model source without `python fmu_sources/coupling/build.py` leaves a stale FMU behind
    import zipfile
    c_dir, py_dir = REPO / "tests" / "fmus_c", REPO / "fmu_sources" / "coupling"
    expected = {"MassA": {"sources/MassA.c": c_dir / "MassA.c"}, "MassB": {"sources/MassB.c": c_dir / "MassB.c"},
                "Affine": {"sources/Affine.c": py_dir / "c" / "Affine.c"}}
    for name in ("MassA", "MassB", "Affine"):
        expected[name].update({f"sources/{f}": c_dir / f for f in ("fmi2_framework.c", "framework_common.h",
                                                                 "model_api.h", "oscillator_math.h")})
    for name in ("PyMassA", "PyMassB", "PyAffine"):
        expected[name] = {f"resources/{name}.py": py_dir / f"{name}.py",
                          "resources/cosim_fmi.py": REPO / "fmu_sources" / "uavsim" / "fmi.py"}
    for name, files in expected.items():
        with zipfile.ZipFile(COUPLING / "fmus" / f"{name}.fmu") as z:
            for member, source in files.items():
                assert z.read(member) == source.read_bytes(), f"{name}.fmu: {member} is stale"
