"""The native step driver (master/drivers/native.py) where tests/accelerators/ does not reach (its cases are the
shipped coupling SSPs): connections with a transformation, Integer and Boolean transfers, FMI 3.0 FMUs, failures,
a request to terminate, non-finite outputs, small blocks, the test FMUs of tests/fmu_factory.py. Each runs with the
driver on and off (the reference loop) and must give the same tables, errors and run facts; one chain is also
checked against its explicit-Euler recurrence recomputed here, and run.json says why the driver did not run."""
import numpy as np
import pytest

import master
from master import accel
from master.drivers.native import library
from master.ssp.writer import SspBuilder

pytestmark = [pytest.mark.skipif(library()[0] is None, reason=f"native loop unavailable: {library()[1]}"),
              pytest.mark.skipif(not accel.enabled(), reason=f"{accel.ENV} is set: no step driver runs")]


def _both(ssp, **kw):
    """(native result, Python-path result); failures are returned in the metadata."""
    on = master.run(ssp, output=None, raise_on_error=False, **kw)
    off = master.run(ssp, output=None, raise_on_error=False, native_loop=False, **kw)
    assert off.metadata["native_loop"] == {"used": False, "reason": "switched off"}
    return on, off


def _same(on, off):
    a, b = on.frame, off.frame
    assert list(a.columns) == list(b.columns)
    assert len(a) == len(b) == on.metadata["rows_recorded"]
    for c in a.columns:     # bit-identical, not close
        assert np.array_equal(a[c].to_numpy(), b[c].to_numpy()), c
    for key in ("outcome", "error", "failed_at", "last_time", "steps_done", "ended_early", "fmu_calls"):
        assert on.metadata.get(key) == off.metadata.get(key), key


def _chain(tmp_path, test_fmus, n=4, step=0.1, stop=3.0, factor=None, offset=None):
    b = SspBuilder("chain", stop=stop, step=step)
    for i in range(n):
        b.add_component(f"I{i}", test_fmus["c2:Integrator"], params={"a": -0.5, "x0": 1.0 + i})
    for i in range(1, n):
        b.connect(f"I{i - 1}", "y", f"I{i}", "u", factor=factor, offset=offset)
    b.connect(f"I{n - 1}", "y", "I0", "u", factor=factor, offset=offset)      # a loop, no feedthrough
    return b.write(tmp_path / "chain.ssp")


@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel"])
def test_chain_with_transforms_and_record_interval(tmp_path, test_fmus, algorithm):
    ssp = _chain(tmp_path, test_fmus, factor=1.5, offset=-0.25)
    on, off = _both(ssp, algorithm=algorithm, record_interval=0.3)
    # 29: the last step (2.9000000000000004 + 0.1 would end past the stop time 3.0) is stop - t, in Python
    assert on.metadata["native_loop"]["used"] and on.metadata["native_loop"]["steps"] == 29
    _same(on, off)
    assert len(on.frame) == 11          # t = 0, 0.3, ..., 3.0


def test_chain_matches_euler_recurrence(tmp_path, test_fmus):
    """Jacobi: every input of step s is its source's output after step s-1; x += h (a x + u) per FMU."""
    n, h, steps = 4, 0.1, 30
    ssp = _chain(tmp_path, test_fmus, n=n, step=h, stop=steps * h, factor=1.5, offset=-0.25)
    on = master.run(ssp, output=None, algorithm="jacobi")
    assert on.metadata["native_loop"]["used"]
    x = 1.0 + np.arange(n)
    rows = [x.copy()]
    stop = steps * h
    for s in range(steps):          # the last step ends at the stop time exactly: stop - t, not h
        u = np.roll(x, 1) * 1.5
        u = u + -0.25
        hs = h if s < steps - 1 or (s * h + h == stop) else stop - s * h
        x = x + hs * (-0.5 * x + u)
        rows.append(x.copy())
    got = on.frame[[f"I{i}.y" for i in range(n)]].to_numpy()
    np.testing.assert_array_equal(got, np.array(rows))


def _masses(tmp_path, test_fmus):
    """Two masses coupled through a feedthrough force (B.F depends on B.x_in)."""
    b = SspBuilder("masses", stop=2.0, step=0.01)
    b.add_component("A", test_fmus["c2:MassA"])
    b.add_component("B", test_fmus["c2:MassB"])
    b.connect("A", "x", "B", "x_in")
    b.connect("B", "F", "A", "F")
    return b.write(tmp_path / "masses.ssp")


def test_integer_and_boolean_transfers(tmp_path, reference_fmus):
    """Reference FMUs: Stair's Integer counter and Feedthrough's Boolean output feed another Feedthrough."""
    b = SspBuilder("ints", stop=3.0, step=0.05)
    b.add_component("S", reference_fmus / "fmi2" / "Stair.fmu")
    b.add_component("F1", reference_fmus / "fmi2" / "Feedthrough.fmu", params={"Boolean_input": True})
    b.add_component("F2", reference_fmus / "fmi2" / "Feedthrough.fmu")
    b.connect("S", "counter", "F1", "Int32_input")
    b.connect("F1", "Int32_output", "F2", "Int32_input")
    b.connect("F1", "Boolean_output", "F2", "Boolean_input")
    ssp = b.write(tmp_path / "ints.ssp")
    on, off = _both(ssp, record=["F2.Int32_output", "F2.Boolean_output", "S.counter"])
    assert on.metadata["native_loop"]["used"]
    _same(on, off)
    counter = on.frame["F2.Int32_output"].to_numpy()
    assert counter[-1] > counter[0] and np.all(np.diff(counter) >= 0)     # the counter went through, in steps
    assert on.frame["F2.Boolean_output"].all()


def _faulty(tmp_path, test_fmus, mode):
    b = SspBuilder("faulty", stop=1.0, step=0.1)
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": mode, "fail_time": 0.5})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("f", "y", "g", "u")
    return b.write(tmp_path / f"faulty{mode}.ssp")


def test_fmu_error_mid_run(tmp_path, test_fmus):
    on, off = _both(_faulty(tmp_path, test_fmus, 1))
    assert on.metadata["outcome"] == "error" and "doStep returned Error" in on.metadata["error"]
    assert on.metadata["failed_at"] == pytest.approx(0.5)
    _same(on, off)
    assert len(on.frame) == 6           # t = 0 .. 0.5: the rows before the failure are kept


def test_fmu_asks_to_terminate(tmp_path, test_fmus):
    on, off = _both(_faulty(tmp_path, test_fmus, 2))
    assert on.metadata["outcome"] == "completed"
    assert "asked to terminate" in on.metadata["ended_early"]["reason"]
    _same(on, off)


def test_nonfinite_output(tmp_path, test_fmus):
    b = SspBuilder("blowup", stop=1.0, step=0.1)
    b.add_component("I", test_fmus["c2:Integrator"], params={"a": 1e300, "x0": 1.0})
    b.add_component("G", test_fmus["c2:Gain"])
    b.connect("I", "y", "G", "u")
    on, off = _both(b.write(tmp_path / "blowup.ssp"))
    assert on.metadata["outcome"] == "error" and "non-finite" in on.metadata["error"]
    _same(on, off)


def test_small_blocks_flushed(tmp_path, test_fmus, monkeypatch):
    """Blocks of 4 rows: the loop returns to Python at every full block and goes on."""
    from master.observers import recording
    init = recording.Recording.__init__
    monkeypatch.setattr(recording.Recording, "__init__",
                        lambda self, *a, **kw: init(self, *a, **{**kw, "block_rows": 4}))
    on, off = _both(_chain(tmp_path, test_fmus))
    assert on.metadata["native_loop"]["used"]
    _same(on, off)


def test_python_path_where_needed(tmp_path, test_fmus):
    """A pythonfmu FMU in the system, or a rollback algorithm: the Python path, with the reason."""
    b = SspBuilder("mixed", stop=0.5, step=0.1)
    b.add_component("I", test_fmus["c2:Integrator"])
    b.add_component("P", test_fmus["py:Integrator"])
    b.connect("I", "y", "P", "u")
    mixed = master.run(b.write(tmp_path / "mixed.ssp"), output=None)
    assert mixed.metadata["native_loop"] == {"used": False, "reason": "component P is not a native FMI 2.0 or 3.0 "
                                                                         "co-simulation FMU"}
    it = master.run(_masses(tmp_path, test_fmus), output=None, algorithm="iterative")
    assert not it.metadata["native_loop"]["used"] and "iterative" in it.metadata["native_loop"]["reason"]
    # extrapolated inputs, also when only one output has an order of its own (the loop would silently hold them)
    for kw in ({"extrapolation": 1}, {"extrapolation_for": {"A.x": 1}}, {"algorithm": "gauss-seidel",
                                                                          "gs_interpolation": 1}):
        ex = master.run(_masses(tmp_path, test_fmus), output=None, **kw)
        assert not ex.metadata["native_loop"]["used"] and "not a fixed sequence" in ex.metadata["native_loop"]["reason"]


def test_cli_switch_recorded(tmp_path, test_fmus):
    """--no-native-loop turns it off, supervised (the CLI's default) or not; a supervised run uses the loop
    (tests/master/drivers/test_native_loop_supervised.py: crashes in it)."""
    import json

    from cli_in_process import run_cli
    ssp = _chain(tmp_path, test_fmus, n=2, stop=0.5)
    cases = ((["--no-supervise"], {"used": True, "steps": 5}),
             (["--no-supervise", "--no-native-loop"], {"used": False, "reason": "switched off"}),
             ([], {"used": True, "steps": 5}),
             (["--no-native-loop"], {"used": False, "reason": "switched off"}))
    for k, (flags, expected) in enumerate(cases):
        out = tmp_path / f"out{k}"
        r = run_cli(["run", str(ssp), "-o", str(out), *flags])        # in-process: the switch is the subject
        assert r.returncode == 0, r.stderr
        assert json.loads((out / "run.json").read_text())["native_loop"] == expected


@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel"])
def test_fmi3_and_fmi2_together(tmp_path, test_fmus, algorithm):
    """FMI 3.0 integrators (fmi3DoStep with its flags) in a loop with FMI 2.0 ones, one on a step multiple."""
    b = SspBuilder("fmi3", stop=2.0, step=0.1)
    b.add_component("A", test_fmus["c3:Integrator"], params={"a": -0.5, "x0": 1.0})
    b.add_component("B", test_fmus["c2:Integrator"], params={"a": -0.25, "x0": 2.0})
    b.add_component("C", test_fmus["c3:Integrator"], params={"a": -1.0, "x0": 3.0})
    b.connect("A", "y", "B", "u", factor=2.0, offset=0.5)
    b.connect("B", "y", "C", "u")
    b.connect("C", "y", "A", "u")
    on, off = _both(b.write(tmp_path / "fmi3.ssp"), algorithm=algorithm, step_multiples={"C": 2},
                    record_interval=0.3)
    assert on.metadata["native_loop"] == {"used": True, "steps": 20}
    _same(on, off)
