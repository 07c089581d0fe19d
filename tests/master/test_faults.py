"""Fault injection: a run never loses, corrupts or hides what it recorded. Crashing and hanging native FMUs,
Ctrl-C and SIGTERM at random points (in the terminal's way: the whole process group; and to the master
alone), a full disk, an output path that is a file. After each: exit status, one line on stderr naming what
happened, and results.parquet, results.csv and run.json readable and telling the same story."""
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import master
import program_server
from cli_in_process import run_cli
from master.errors import CosimError
from master.ssp.writer import SspBuilder

CLI = [sys.executable, "-m", "master.cli"]


def _env():
    return dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))


def _faulty(tmp_path, test_fmus, mode, fail_time=0.5, step=0.1, stop=1.0, name="faulty"):
    b = SspBuilder(name, stop=stop, step=step)
    b.add_component("f", test_fmus["c2:Faulty"], params={"mode": mode, "fail_time": fail_time})
    b.add_component("g", test_fmus["c2:Gain"], params={"k": 2.0})
    b.connect("f", "y", "g", "u")
    return b.write(tmp_path / f"{name}_{mode}.ssp")


def _long_chain(tmp_path, test_fmus, stop=40.0, step=1e-4):
    """Two integrators in a loop, 400,000 steps recorded at every step: seconds of writing to interrupt."""
    b = SspBuilder("long", stop=stop, step=step)
    b.add_component("I1", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 1.0})
    b.add_component("I2", test_fmus["c2:Integrator"], params={"a": -0.01, "x0": 0.0})
    b.connect("I1", "y", "I2", "u")
    b.connect("I2", "y", "I1", "u")
    return b.write(tmp_path / "long.ssp")


def _consistent(out: Path, step: float) -> pd.DataFrame:
    """Parquet, CSV and run.json agree, time runs forward on the step grid; returns the table."""
    meta = json.loads((out / "run.json").read_text())
    df = pq.read_table(out / "results.parquet").to_pandas()
    csv = pd.read_csv(out / "results.csv")
    assert len(df) == len(csv) == meta["rows_recorded"], (len(df), len(csv), meta["rows_recorded"])
    assert np.array_equal(df.to_numpy(), csv.to_numpy())
    t = df["time"].to_numpy()
    assert np.all(np.diff(t) > 0)
    np.testing.assert_allclose(t, step * np.arange(len(t)), rtol=0, atol=1e-9 * max(1.0, t[-1] if len(t) else 1))
    assert not list(out.glob("*.tmp")) and not (out / ".cosim-master.reserve").exists()
    return df


def _one_line(stderr: str) -> str:
    lines = [ln for ln in stderr.strip().splitlines() if ln.startswith("cosim-master:")]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


# -- crashing and hanging FMUs ----------------------------------------------------------------------------
@pytest.mark.parametrize("mode,sig", [(3, "SIGABRT"), (4, "SIGSEGV")])
def test_a_crashing_fmu_leaves_every_row_and_names_the_component(tmp_path, test_fmus, mode, sig):
    out = tmp_path / "out"
    r = program_server.run(CLI + ["run", str(_faulty(tmp_path, test_fmus, mode)), "-o", str(out), "--record", "*.y"],
                       capture_output=True, text=True, env=_env(), timeout=120)
    assert r.returncode == 1
    line = _one_line(r.stderr)
    assert f"killed by signal {sig}" in line and "component f" in line and "t=0.5" in line, line
    df = _consistent(out, 0.1)
    # the step from 0.5 crashed: rows at 0, 0.1, ..., 0.5; f.y = t, and g.y = 2 f.y one (Jacobi) step later
    assert len(df) == 6
    np.testing.assert_allclose(df["f.y"], df["time"], atol=1e-12)
    np.testing.assert_allclose(df["g.y"], np.maximum(0.0, 2 * (df["time"] - 0.1)), atol=1e-12)
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "crashed" and meta["supervised"]["rows_recovered"] == 6


def test_rows_of_sent_blocks_and_of_the_unfinished_block_are_all_kept(tmp_path, test_fmus):
    # 5001 rows before the crash: one full block of 4096 went through the pipe, 905 were in shared memory
    out = tmp_path / "out"
    ssp = _faulty(tmp_path, test_fmus, 3, fail_time=5.0, step=0.001, stop=10.0)
    r = program_server.run(CLI + ["run", str(ssp), "-o", str(out)], capture_output=True, text=True, env=_env(),
                       timeout=120)
    assert r.returncode == 1 and "SIGABRT" in r.stderr
    df = _consistent(out, 0.001)
    assert len(df) == 5001 and json.loads((out / "run.json").read_text())["supervised"]["rows_recovered"] == 905


def test_a_hanging_fmu_is_stopped_by_the_timeout(tmp_path, test_fmus):
    out = tmp_path / "out"
    t0 = time.monotonic()
    r = program_server.run(CLI + ["run", str(_faulty(tmp_path, test_fmus, 5)), "-o", str(out), "--timeout", "2"],
                       capture_output=True, text=True, env=_env(), timeout=120)
    assert time.monotonic() - t0 < 30
    assert r.returncode == 1
    line = _one_line(r.stderr)
    assert "timed out after 2 s" in line and "component f" in line and "t=0.5" in line, line
    assert len(_consistent(out, 0.1)) == 6


def test_ctrl_c_ends_a_hanging_fmu_with_exit_130(tmp_path, test_fmus):
    out = tmp_path / "out"
    p = program_server.Popen(CLI + ["run", str(_faulty(tmp_path, test_fmus, 5)), "-o", str(out)], env=_env(),
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    # well into the hang (it starts at t = 0.5 of a few-ms run): the results file is opened once the child has
    # initialized; a fixed delay alone met a busy machine's start-up (imports, unpacking) as often as the hang
    deadline = time.monotonic() + 60
    while not (out / "results.parquet").exists() and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(1.0)
    os.killpg(p.pid, signal.SIGINT)      # what a terminal's Ctrl-C does
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130
    line = _one_line(err)
    assert "interrupted by the user" in line and "component f" in line and str(out) in line, line
    assert len(_consistent(out, 0.1)) == 6


# -- interrupts at random points while results are written -------------------------------------------------
@pytest.mark.parametrize("how", ["group-sigint", "sigterm", "in-process-sigint"])
def test_interrupts_at_random_points_leave_consistent_results(tmp_path, test_fmus, how):
    ssp = _long_chain(tmp_path, test_fmus)
    rnd = random.Random(7)
    for k in range(3):
        out = tmp_path / f"out{k}"
        args = CLI + ["run", str(ssp), "-o", str(out)] + (["--no-supervise"] if how.startswith("in-process") else [])
        p = program_server.Popen(args, env=_env(), stderr=subprocess.PIPE, text=True, start_new_session=True)
        # the random point is counted from the moment the results file is opened (after initialization): on a
        # loaded machine the start-up (imports, unpacking, instantiation) alone can take longer than the delay,
        # and an interrupt then finds nothing to keep
        deadline = time.monotonic() + 60
        while not (out / "results.parquet").exists() and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(rnd.uniform(0.05, 1.2))      # the native loop runs the 400,000 steps in about a second
        if how == "sigterm":
            p.send_signal(signal.SIGTERM)
        else:
            os.killpg(p.pid, signal.SIGINT)
        _, err = p.communicate(timeout=120)
        if p.returncode == 0:       # the run finished first on a fast machine: still must be consistent
            _consistent(out, 1e-4)
            continue
        assert p.returncode == (143 if how == "sigterm" else 130), err
        meta = json.loads((out / "run.json").read_text())
        if meta["outcome"] == "completed":      # it came while the finished run was written: held until whole
            assert len(_consistent(out, 1e-4)) == 400001
            continue
        _one_line(err)
        assert meta["outcome"] == "interrupted"
        df = _consistent(out, 1e-4)
        assert 0 < len(df) < 400001


# -- a full disk ----------------------------------------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path):
    mnt = tmp_path / "small"
    mnt.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=6m", "tmpfs", str(mnt)], capture_output=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (needs root): " + r.stderr.decode().strip())
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


@pytest.mark.parametrize("supervised", [True, False])
def test_a_full_disk_keeps_readable_and_equal_results(tmp_path, test_fmus, small_disk, supervised):
    ssp = _long_chain(tmp_path, test_fmus, stop=20.0)        # ~10 MB of CSV: does not fit in 6 MB
    out = small_disk / "out"
    r = run_cli(["run", str(ssp), "-o", str(out)] + ([] if supervised else ["--no-supervise"]))   # in-process
    assert r.returncode == 1
    line = _one_line(r.stderr)
    assert "disk full while writing" in line and "component" not in line, line
    df = _consistent(out, 1e-4)
    assert len(df) > 0          # (every row that fitted, not whole blocks only: the RLIMIT_FSIZE tests below)
    meta = json.loads((out / "run.json").read_text())
    assert any("rebuilt" in n for n in meta.get("results_notes", [])) or len(df) > 0


@pytest.mark.parametrize("supervised", [True, False])
def test_a_disk_full_from_the_start_is_one_line(tmp_path, test_fmus, small_disk, supervised):
    """issue 25: with no room at all, the supervised run hung (its child waiting for a block that the parent
    could not open) and the unsupervised one ended in a cascade of tracebacks (results, fmu.log, run.json)."""
    with open(small_disk / "filler", "wb") as fh:        # every block of the disk taken
        try:
            while True:
                fh.write(b"\0" * 65536)
                fh.flush()
        except OSError:
            pass
    out = small_disk / "out"
    r = run_cli(["run", str(_faulty(tmp_path, test_fmus, 0)), "-o", str(out)] + ([] if supervised else
                                                                                ["--no-supervise"]))
    assert r.returncode == 1
    line = _one_line(r.stderr)
    assert "results: disk full while writing" in line and "component" not in line, line
    assert not (out / "results.parquet").exists() and not (out / "results.csv").exists()
    assert not (out / ".cosim-master.reserve").exists()


# A file size limit (RLIMIT_FSIZE, `ulimit -f`) is a full disk for each file, with no root needed: the write that
# passes it fails with EFBIG (the program ignores SIGXFSZ, which would kill it). The rows that fit are then known
# exactly: the whole lines of the unlimited run's CSV within the limit (the CSV is the larger file).
LIMIT = 150_000     # bytes; above the supervisor's shared block of 4096 rows x 3 columns (98 KB)


@pytest.mark.parametrize("stop", [40.0, 200.0], ids=["last-block-at-the-end", "mid-run"])
@pytest.mark.parametrize("supervised", [True, False], ids=["supervised", "no-supervise"])
def test_a_file_size_limit_keeps_every_row_that_fitted(tmp_path, test_fmus, stop, supervised):
    """issue 25: a full disk lost the whole block being written (up to 4096 rows); a run that reached its end
    (its only block written at the end) kept 0 rows."""
    ssp = _long_chain(tmp_path, test_fmus, stop=stop, step=0.01)    # 4001 / 20001 rows of ~45 bytes
    ref = master.run(ssp, output=tmp_path / "ref")
    ref_csv = (tmp_path / "ref" / "results.csv").read_bytes()
    assert len(ref_csv) > LIMIT
    fit = ref_csv[:LIMIT].count(b"\n") - 1             # whole lines within the limit, the header aside
    out = tmp_path / "out"
    args = CLI + ["run", str(ssp), "-o", str(out)] + ([] if supervised else ["--no-supervise"])
    import resource
    r = program_server.run(args, capture_output=True, text=True, env=dict(_env(), PYTHONDONTWRITEBYTECODE="1"),
                           timeout=120, rlimits={resource.RLIMIT_FSIZE: (LIMIT, LIMIT)})
    assert r.returncode == 1, r.stderr
    line = _one_line(r.stderr)
    assert "file size limit reached while writing" in line and "component" not in line, line
    assert f"({fit} rows recorded until then" in line, line
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "error" and "file size limit reached while writing" in meta["error"]
    df = _consistent(out, 0.01)
    assert len(df) == fit
    assert (out / "results.csv").read_bytes() == ref_csv[:ref_csv[:LIMIT].rindex(b"\n") + 1]
    expected = pq.read_table(tmp_path / "ref" / "results.parquet").slice(0, fit)
    assert pq.read_table(out / "results.parquet").equals(expected)      # bit for bit, a valid footer


class _Full:
    """A file that takes ``room`` bytes and then fails as a full disk does (a partial write, then ENOSPC)."""
    def __init__(self, fh, room):
        self.fh, self.room = fh, room

    def write(self, data):
        import errno
        n = min(len(data), self.room - self.fh.tell())
        if n <= 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.fh.write(bytes(data[:n]))
        return n

    def __getattr__(self, name):
        return getattr(self.fh, name)


def test_a_full_disk_at_the_sinks_keeps_every_row_that_fitted(tmp_path):
    """The same at the sinks' boundary, with ENOSPC: the CSV full after 1000.5 rows keeps 1000 whole rows, and
    the Parquet file (its block failed with it) is rebuilt from them with a valid footer."""
    import pyarrow as pa

    from master.sinks.csv import CsvSink
    from master.sinks.group import SinkGroup
    from master.sinks.parquet import ParquetSink
    schema = pa.schema([("time", pa.float64()), ("x", pa.float64())])
    t = np.arange(3000) * 0.25
    table = pa.table({"time": t, "x": np.sqrt(t)}, schema=schema)
    line = [(f"{a!r},{b!r}\n").encode() for a, b in zip(t.tolist(), np.sqrt(t).tolist())]
    header = b"time,x\n"
    room = len(header) + sum(map(len, line[:1000])) + len(line[1000]) // 2
    csv, parquet = CsvSink(), ParquetSink()
    group = SinkGroup([parquet, csv], tmp_path)
    group.open(schema)
    csv._fh = _Full(csv._fh, room)
    group.write(table.slice(0, 600))
    with pytest.raises(CosimError, match=r"results: disk full while writing .*results\.csv$"):
        group.write(table.slice(600))
    group.close()
    assert group.rows == 1000
    assert (tmp_path / "results.csv").read_bytes() == header + b"".join(line[:1000])
    assert pq.read_table(tmp_path / "results.parquet").equals(table.slice(0, 1000))
    assert not (tmp_path / ".cosim-master.reserve").exists()


def test_an_output_path_that_is_a_file_is_one_line(tmp_path, test_fmus):
    target = tmp_path / "taken"
    target.write_text("mine")
    for extra in ([], ["--no-supervise"]):
        r = run_cli(["run", str(_faulty(tmp_path, test_fmus, 0)), "-o", str(target)] + extra)     # in-process
        assert r.returncode == 1
        assert "the output folder is a file, not a folder" in _one_line(r.stderr)
        assert target.read_text() == "mine"


def test_the_api_raises_with_the_result_attached(tmp_path, test_fmus):
    from master.supervise import run_supervised
    with pytest.raises(CosimError, match="SIGABRT") as e:
        run_supervised(_faulty(tmp_path, test_fmus, 3), output=tmp_path / "api")
    assert e.value.result.metadata["rows_recorded"] == 6


@pytest.mark.parametrize("failing", ["run.json.tmp", "events.csv.tmp"])
def test_a_run_file_that_does_not_fit_leaves_the_old_one_and_no_tmp(tmp_path, monkeypatch, failing):
    """issue 25: a disk that fills while run.json (or events.csv) is written left a 0-byte ``.tmp`` beside it."""
    import errno

    from master import execution
    out = tmp_path / "run"
    out.mkdir()
    (out / "run.json").write_text('{"outcome": "completed", "earlier": true}\n')
    real_write_text, real_events = Path.write_text, execution.write_events_csv

    def full(path):
        with open(path, "w") as fh:             # the file is created, then the disk is full
            fh.write("")
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(Path, "write_text", lambda self, *a, **k: full(self) if self.name == failing
                        else real_write_text(self, *a, **k))
    monkeypatch.setattr(execution, "write_events_csv", lambda ev, path: full(path) if path.name == failing
                        else real_events(ev, path))
    with pytest.raises(OSError):
        execution.write_run_files(out, {"outcome": "error"}, [{"time": 1.0, "event": "collision"}])
    assert not (out / failing).exists()
    assert json.loads((out / "run.json").read_text())["earlier"] is True
