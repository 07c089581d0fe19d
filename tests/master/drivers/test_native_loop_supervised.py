"""The native step loop under supervision (the CLI's default): it runs, its results are those of the Python
path and of an unsupervised run bit for bit, and an FMU that crashes or hangs inside the C loop is reported
as on the Python path: the same one-line error (component, phase, time), the same rows kept. The Python path
(--no-native-loop) is the reference for the equalities; the expected component, time and rows come from the
Faulty model itself (y = time; it fails in the first doStep that ends after fail_time)."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import master
import program_server
from master import accel
from master.drivers.native import library
from master.ssp.writer import SspBuilder

pytestmark = [pytest.mark.skipif(library()[0] is None, reason=f"native loop unavailable: {library()[1]}"),
              pytest.mark.skipif(not accel.enabled(), reason=f"{accel.ENV} is set: no step driver runs")]

CLI = [sys.executable, "-m", "master.cli"]


def _env():
    return dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))


def _faulty(tmp_path, test_fmus, mode, fail_time=0.5, step=0.1, stop=1.0):
    b = SspBuilder("faulty", stop=stop, step=step)
    b.add_component("g0", test_fmus["c2:Gain"], params={"k": 3.0})     # index 0: the culprit is not the first
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": mode, "fail_time": fail_time})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("f", "y", "g", "u")
    b.connect("g", "y", "g0", "u")
    return b.write(tmp_path / f"faulty_{mode}_{fail_time:g}.ssp")


def _run(ssp, out, *flags):
    r = program_server.run(CLI + ["run", str(ssp), "-o", str(out), *flags], capture_output=True, text=True,
                       env=_env(), timeout=180)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.startswith("cosim-master:")]
    assert "Traceback" not in r.stderr, r.stderr
    meta = json.loads((out / "run.json").read_text())
    df = pq.read_table(out / "results.parquet").to_pandas() if (out / "results.parquet").exists() else None
    return r.returncode, lines, meta, df


def _same_frames(a: pd.DataFrame, b: pd.DataFrame):
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    for c in a.columns:            # bit for bit, not close
        assert np.array_equal(a[c].to_numpy(), b[c].to_numpy()), c


# with rows every 0.2 s the time reached (0.5) is not the last row's (0.4): the error must name the former
@pytest.mark.parametrize("mode,how,every", [(3, "killed by signal SIGABRT", 0.1), (4, "killed by signal SIGSEGV", 0.2),
                                            (5, "timed out after 2 s", 0.1)])
def test_a_crash_in_the_c_loop_reads_as_on_the_python_path(tmp_path, test_fmus, mode, how, every):
    ssp = _faulty(tmp_path, test_fmus, mode)
    extra = ["--record-interval", str(every)] + (["--timeout", "2"] if mode == 5 else [])
    native = _run(ssp, tmp_path / "native", *extra)
    python = _run(ssp, tmp_path / "python", "--no-native-loop", *extra)
    code, lines, meta, df = native
    assert meta["native_loop"] == {"used": True} and "native_loop" not in python[2]   # the child's facts died
    assert code == python[0] == 1
    # one line, naming the component whose doStep crashed and the time the run had reached: the step from 0.5
    assert len(lines) == 1 and how in lines[0] and "component f" in lines[0] and "t=0.5" in lines[0], lines
    assert lines == [ln.replace(str(tmp_path / "python"), str(tmp_path / "native")) for ln in python[1]]
    for key in ("outcome", "error", "failed_component", "last_time", "rows_recorded", "supervised"):
        expected = python[2].get(key)
        if key == "error":
            expected = expected.replace(str(tmp_path / "python"), str(tmp_path / "native"))
        assert meta.get(key) == expected, key
    # rows at t = 0, every, ... up to 0.5; f.y = t and g.y = 2 f.y one (Jacobi) step later
    times = np.arange(0, 0.5 + 1e-9, every)
    assert meta["failed_component"] == "f" and len(df) == len(times)
    np.testing.assert_allclose(df["time"], times, atol=1e-12)
    np.testing.assert_allclose(df["f.y"], times, atol=1e-12)
    np.testing.assert_allclose(df["g.y"], np.maximum(0.0, 2 * (df["time"] - 0.1)), atol=1e-12)
    _same_frames(df, python[3])


def test_a_crash_after_whole_blocks_keeps_the_sent_blocks_and_the_unfinished_one(tmp_path, test_fmus):
    """5001 rows before the crash at t = 5: one block of 4096 rows written from the pipe, 905 from shared
    memory; the C loop filled both."""
    ssp = _faulty(tmp_path, test_fmus, 3, fail_time=5.0, step=0.001, stop=10.0)
    code, lines, meta, df = _run(ssp, tmp_path / "native")
    assert meta["native_loop"] == {"used": True}
    assert code == 1 and "SIGABRT" in lines[0] and "component f" in lines[0] and "t=5" in lines[0], lines
    assert len(df) == 5001 and meta["supervised"]["rows_recovered"] == 905
    np.testing.assert_allclose(df["time"], np.arange(5001) * 0.001, rtol=0, atol=1e-9)
    np.testing.assert_allclose(df["f.y"], df["time"], rtol=0, atol=1e-12)      # y = time (the FMU sums its h)
    python = _run(ssp, tmp_path / "python", "--no-native-loop")
    _same_frames(df, python[3])
    assert meta["supervised"] == python[2]["supervised"] and meta["rows_recorded"] == python[2]["rows_recorded"]


def _chain(tmp_path, test_fmus, n=4, step=0.01, stop=3.0):
    b = SspBuilder("chain", stop=stop, step=step)
    for i in range(n):
        b.add_component(f"I{i}", test_fmus["c2:Integrator"], params={"a": -0.5, "x0": 1.0 + i})
    for i in range(1, n):
        b.connect(f"I{i - 1}", "y", f"I{i}", "u", factor=1.5, offset=-0.25)
    b.connect(f"I{n - 1}", "y", "I0", "u")
    return b.write(tmp_path / "chain.ssp")


def test_supervised_native_results_equal_unsupervised_and_python_path(tmp_path, test_fmus, monkeypatch):
    """Blocks of 16 rows (the minimum), so that the C loop hands many full blocks to the pipe; the child is a
    fork of this process, so the smaller blocks apply to it too."""
    from master.observers import recording
    from master.supervise import run_supervised
    init = recording.Recording.__init__
    monkeypatch.setattr(recording.Recording, "__init__",
                        lambda self, *a, **kw: init(self, *a, **{**kw, "block_rows": 16}))
    ssp = _chain(tmp_path, test_fmus)
    sup = run_supervised(ssp, output=tmp_path / "sup", algorithm="gauss-seidel", record_interval=0.03)
    sup_py = run_supervised(ssp, output=tmp_path / "sup_py", algorithm="gauss-seidel", record_interval=0.03,
                            native_loop=False)
    plain = master.run(ssp, output=tmp_path / "plain", algorithm="gauss-seidel", record_interval=0.03)
    assert sup.metadata["native_loop"] == {"used": True, "steps": 300}
    assert plain.metadata["native_loop"] == {"used": True, "steps": 300}
    assert sup_py.metadata["native_loop"] == {"used": False, "reason": "switched off"}
    assert len(sup.frame) == 101 and sup.metadata["rows_recorded"] == 101      # t = 0, 0.03, ..., 3.0
    _same_frames(sup.frame, plain.frame)
    _same_frames(sup.frame, sup_py.frame)
    for key in ("fmu_calls", "last_time", "steps_done", "outcome"):
        assert sup.metadata.get(key) == plain.metadata.get(key) == sup_py.metadata.get(key), key


# The three choices act at different places: the loop (C, or Python), the signal's way in (a Ctrl-C reaches both
# processes; a SIGTERM to the supervisor is passed on by it) and where the child's handler runs (in the logger
# callback when logging is on). Each pair of choices meets in one of these four runs (pairwise), as in the
# whole 2 x 2 x 2 product: every choice that fails alone or with one other fails here too.
@pytest.mark.parametrize("flags,how,log", [([], "group-sigint", "none"), ([], "sigterm", "info"),
                                           (["--no-native-loop"], "group-sigint", "info"),
                                           (["--no-native-loop"], "sigterm", "none")])
def test_an_interrupt_with_slow_fmus_closes_the_run_in_order(tmp_path, test_fmus, flags, how, log):
    """Every doStep of f sleeps 20 ms (Faulty mode 6): 1000 steps are 20 s. The child serves the interrupt
    itself (exit 130 or 143, its own run.json, every row, steps and rows agreeing) instead of the supervisor
    killing it after its grace time: a call into the C loop is paced to about 0.1 s. With logging on, mode 6
    logs at the end of every doStep, so the signal that arrived during its sleep has its handler run inside
    the logger callback, where ctypes would drop the interrupt (master.interrupts sends it again)."""
    import signal
    import time
    ssp = _faulty(tmp_path, test_fmus, 6, fail_time=0.0, step=0.1, stop=100.0)
    out = tmp_path / "out"
    p = program_server.Popen(CLI + ["run", str(ssp), "-o", str(out), "--log-level", log, *flags], env=_env(),
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    while not (out / "results.parquet").exists() and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.5)
    if how == "sigterm":
        p.send_signal(signal.SIGTERM)         # to the master alone: it passes it on
    else:
        os.killpg(p.pid, signal.SIGINT)       # what a terminal's Ctrl-C does
    _, err = p.communicate(timeout=60)
    assert p.returncode == (143 if how == "sigterm" else 130), err
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "interrupted" and meta.get("native_loop", {}).get("used") == (not flags), err
    assert meta["supervised"] == {"child_exit": p.returncode} and "killed" not in err, err
    df = pq.read_table(out / "results.parquet").to_pandas()
    steps = meta["steps_done"]
    assert 0 < steps < 1000 and len(df) == meta["rows_recorded"] == steps + 1
    assert meta["last_time"] == pytest.approx(0.1 * steps)
    np.testing.assert_allclose(df["time"], np.arange(steps + 1) * 0.1, rtol=0, atol=1e-9)
