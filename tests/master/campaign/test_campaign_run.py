"""Campaign execution end to end on a small generic SSP: failures, crashes, resume, stale inputs, worker
counts and the Dask path give the same table."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import program_server
from campaign_helpers import local_cluster, write_chain_ssp
from cli_in_process import run_cli
from master.campaign.runner import run_campaign
from master.campaign.spec import load_campaign, seed_for

ROOT = Path(__file__).resolve().parents[3]

CAMPAIGN = """\
name: chain
seed: 11
repetitions: 2
scenario: chain.ssp
grid:
  param:gain.k: [1.0, 2.0, 3.0]
runs:
  - {param:gain.k: 5.0, param:src.mode: 1}      # the FMU returns Error in doStep: a Python-level failure
  - {param:src.mode: 3}                          # the FMU calls abort() in doStep: the worker dies
run:
  stop_time: 1.0
  step: 0.1
"""


def write_campaign(folder: Path, text: str = CAMPAIGN) -> Path:
    p = folder / "campaign.yaml"
    p.write_text(text)
    return p


def table(folder: Path) -> pd.DataFrame:
    return pd.read_parquet(folder / "results.parquet")


def same_tables(a: pd.DataFrame, b: pd.DataFrame, drop=("wall_time_s",)):
    pd.testing.assert_frame_equal(_comparable(a, drop), _comparable(b, drop))


def _comparable(df: pd.DataFrame, drop) -> pd.DataFrame:
    """Without the columns that differ between equal campaigns, and with the errors' paths relative to the
    campaign folder (an FMU's error names its file)."""
    return df.drop(columns=list(drop)).assign(
        error=df["error"].str.replace(r"^.*/chain\.ssp/", "chain.ssp/", regex=True))


@pytest.fixture(scope="module")
def reference(tmp_path_factory, chain_fmus):
    """The uninterrupted campaign on 2 worker processes (shared by several tests)."""
    d = tmp_path_factory.mktemp("ref")
    write_chain_ssp(d / "chain.ssp", chain_fmus)
    camp = write_campaign(d)
    s = run_campaign(camp, output=d / "out", workers=2, progress=False)
    return d, camp, s


def test_grid_with_failures_and_a_crash(reference):
    d, camp, s = reference
    out = d / "out"
    assert (s.total, s.completed, s.failed, s.pending) == (10, 6, 4, 0)
    assert not s.ok and s.complete and s.ran_now == 10 and s.worker_restarts == 2
    df = table(out)
    assert len(df) == 10 and list(df.columns[:4]) == ["run_id", "param:gain.k", "param:src.mode", "rep"]
    ok = df[df["run_outcome"] == "completed"]
    assert len(ok) == 6 and ok["error"].isna().all()
    # the recorded results are the runs' own: y = time at the end, the gain output proportional to k
    assert (ok["final:src.y"] == 1.0).all()
    ratio = ok["final:gain.y"] / ok["param:gain.k"]
    assert ratio.nunique() == 1 and ratio.iloc[0] > 0
    bad = df[df["param:src.mode"] == 1]
    assert len(bad) == 2 and (bad["run_outcome"] == "failed").all()
    assert bad["error"].str.contains("Faulty: injected error in doStep").all()
    crash = df[df["param:src.mode"] == 3]
    assert len(crash) == 2 and (crash["error"] == "worker process died with signal 6 (SIGABRT)").all()
    # seeds: derived from the campaign seed, the canonical parameters and the repetition
    c = load_campaign(camp)
    for r in c.runs:
        rec = json.loads((out / "runs" / f"{r.run_id}.json").read_text())
        assert rec["seed"] == seed_for(11, r.params, r.rep) == r.seed
        assert rec["inputs_sha256"] == r.inputs_sha256
    assert not list((out / "runs").glob(".*tmp*"))
    assert "4 failed" in s.describe() and "SIGABRT" in s.describe()


def test_one_worker_gives_the_same_table(reference, tmp_path, chain_fmus):
    d, camp, _ = reference
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    s = run_campaign(write_campaign(tmp_path), output=tmp_path / "out", workers=1, progress=False)
    assert (s.completed, s.failed) == (6, 4)
    same_tables(table(tmp_path / "out"), table(d / "out"))


def test_resume_after_max_runs_gives_the_same_table(reference, tmp_path, chain_fmus):
    d, _, _ = reference
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path)
    out = tmp_path / "out"
    from master.cli import main
    # one worker (the count has its own test; each spawned worker imports the engine anew)
    # the command line's --max-runs / --retry-failed are run_campaign's max_runs / retry_failed
    assert main(["campaign", str(camp), "-o", str(out), "--workers", "1", "--no-progress", "--max-runs", "3"]) == 1
    assert len(table(out)) == 3
    s2 = run_campaign(camp, output=out, workers=1, progress=False)
    assert (s2.skipped, s2.ran_now, s2.pending) == (3, 7, 0)
    same_tables(table(out), table(d / "out"))
    s3 = run_campaign(camp, output=out, workers=1, progress=False)
    assert (s3.skipped, s3.ran_now) == (10, 0)
    same_tables(table(out), table(d / "out"))
    # failed runs are finished runs; retry_failed runs them again (and they fail the same way)
    s4 = run_campaign(camp, output=out, workers=1, progress=False, retry_failed=True)
    assert (s4.skipped, s4.ran_now, s4.failed) == (6, 4, 4)
    same_tables(table(out), table(d / "out"))
    assert main(["campaign", str(camp), "-o", str(out), "--workers", "1", "--no-progress", "--retry-failed",
                 "--max-runs", "1"]) == 1
    same_tables(table(out), table(d / "out"))


SLOW = """\
name: slow
seed: 3
repetitions: 1
scenario: chain.ssp
grid:
  param:gain.k: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]
  param:src.mode: 6
  param:src.fail_time: 0.0
run:
  stop_time: 0.5
  step: 0.02
  csv: false
"""
# 25 steps a run, each of which sleeps 20 ms in the FMU (Faulty's mode 6): long enough (0.5 s) that the campaign
# cannot finish its remaining runs between the second record and the interrupt, on any master, and asleep rather
# than busy (the 30000 steps of 0.1 ms it had burnt ~0.5 s of CPU a run)


# The commands below start as a shell would start them: SIGINT neither ignored nor blocked, whatever this test
# process inherited (a test runner's worker may run with SIGINT ignored, and exec keeps an ignored signal ignored).
# They are forked from the tests' program server (tests/program_server.py), which has imported the CLI already.
SHELL_SIGNALS = {signal.SIGINT}


def test_ctrl_c_keeps_only_complete_records_and_resumes(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path, SLOW)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    mine = {k: v for k, v in (line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines()
                              if line.startswith(("SigIgn", "SigBlk")))} if Path("/proc/self/status").exists() else {}
    p = program_server.Popen([sys.executable, "-m", "master.cli", "campaign", str(camp), "-o", str(out),
                              "--workers", "1", "--no-progress"], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, default_signals=SHELL_SIGNALS)
    t0 = time.monotonic()
    deadline = t0 + 60
    while time.monotonic() < deadline and len(list((out / "runs").glob("*.json"))) < 2:
        time.sleep(0.05)
    seen, waited = len(list((out / "runs").glob("*.json"))), time.monotonic() - t0
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 130, (f"SIGINT sent after {waited:.2f} s with {seen} records; "
                               f"{len(list((out / 'runs').glob('*.json')))} at the end; this process: {mine} "
                               f"{signal.getsignal(signal.SIGINT)!r}; {stdout!r} {stderr!r}")
    assert "Interrupted" in stdout
    records = list((out / "runs").glob("*.json"))
    assert 2 <= len(records) < 12
    for r in records:
        assert json.loads(r.read_text())["outcome"] == "completed"
    assert not list((out / "runs").glob(".*tmp*"))
    assert len(table(out)) == len(records)
    s = run_campaign(camp, output=out, workers=2, progress=False)
    assert s.ok and s.skipped == len(records) and s.ran_now == 12 - len(records)
    ref = tmp_path / "ref"
    run_campaign(camp, output=ref, workers=2, progress=False)
    same_tables(table(out), table(ref))


@pytest.mark.parametrize("sig,code,said", [(signal.SIGINT, 130, "Interrupted"), (signal.SIGTERM, 143, "Interrupted")])
def test_a_signal_to_the_process_group_exits_as_run_does(tmp_path, chain_fmus, sig, code, said):
    """issue 25: the docs said 1 and Ctrl-C gave 130; now campaign and run agree (README: Ctrl-C exit 130, SIGTERM
    143) and `campaign --help` says so. The signal goes to the whole group, as a terminal's Ctrl-C or `kill --
    -PGID` send it, once a record exists."""
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path, SLOW)
    out = tmp_path / "out"
    p = program_server.Popen([sys.executable, "-m", "master.cli", "campaign", str(camp), "-o", str(out),
                              "--workers", "1", "--no-progress"], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                             default_signals=SHELL_SIGNALS)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list((out / "runs").glob("*.json")) and p.poll() is None:
        time.sleep(0.02)
    os.killpg(p.pid, sig)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == code, (stdout, stderr)
    assert said in stdout and "Traceback" not in stderr
    records = list((out / "runs").glob("*.json"))
    assert 1 <= len(records) < 12 and len(table(out)) == len(records)
    from master.cli import _parser
    help_text = " ".join(_parser()._subparsers._group_actions[0].choices["campaign"].format_help().split())
    assert "130 after Ctrl-C and 143 after SIGTERM" in help_text


def test_another_campaign_is_not_written_into_a_campaign_folder(tmp_path, chain_fmus):
    """issue 25: a different campaign written into an existing campaign folder silently replaced its
    campaign.yaml, table and report; the same campaign still resumes there."""
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    first = write_campaign(tmp_path, SLOW.replace("[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]", "[1, 2]")
                           .replace("step: 0.02", "step: 0.1"))
    out = tmp_path / "out"
    assert run_campaign(first, output=out, workers=1, progress=False).ok
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    other = tmp_path / "other.yaml"
    other.write_text(first.read_text().replace("name: slow", "name: another"))
    from master.cli import main
    r = run_cli(["campaign", str(other), "-o", str(out), "--no-progress"])     # the command, in this process
    assert r.returncode == 1 and r.stderr.strip() == (
        f"cosim-master: error: {out}: --output: the folder holds the campaign 'slow', not 'another': give another "
        "-o DIR (or remove the folder to start anew)"), r.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before     # left untouched
    s = run_campaign(first, output=out, workers=1, progress=False)          # the same one resumes
    assert s.ok and s.skipped == 2 and s.ran_now == 0
    assert main(["campaign", str(other), "-o", str(tmp_path / "elsewhere"), "--no-progress", "--workers", "1"]) == 0


def test_changed_scenario_makes_records_stale(tmp_path, chain_fmus, monkeypatch):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    without_failing_runs = CAMPAIGN[:CAMPAIGN.index("runs:\n")] + CAMPAIGN[CAMPAIGN.index("run:\n"):]
    camp = write_campaign(tmp_path, without_failing_runs)
    out = tmp_path / "out"
    # one worker process each time (the worker count is test_one_worker_gives_the_same_table's; staleness is
    # decided before any worker runs): each spawned worker imports the engine anew
    s = run_campaign(camp, output=out, workers=1, progress=False)
    assert s.ok and s.total == 6
    before = table(out)
    # same parameters, different scenario file (another default of an unrelated parameter)
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus, k=7.0)
    s = run_campaign(camp, output=out, workers=1, progress=False, max_runs=2)
    assert s.stale == 6 and s.ran_now == 2 and s.pending == 4
    assert s.stale_reasons == {"scenario file chain.ssp changed": 6}
    assert "stale" in s.describe() and "chain.ssp changed" in s.describe()
    # stale records are not mixed into the table
    assert len(table(out)) == 2
    s = run_campaign(camp, output=out, workers=1, progress=False)
    assert s.ok and s.stale == 4 and s.ran_now == 4
    after = table(out)
    assert (after["scenario_sha256"] != before["scenario_sha256"]).all()
    same_tables(after, before, drop=("wall_time_s", "scenario_sha256"))   # k is a grid parameter: same results
    # the master's (or uavsim's) code is an input too: after an upgrade the records are stale
    import master.campaign.identity as identity
    monkeypatch.setattr(identity, "_code_sha", "0" * 64)
    s = run_campaign(camp, output=out, workers=1, progress=False, max_runs=0)
    assert s.stale == 6 and s.stale_reasons == {"cosim-master's code changed": 6}


def test_dask_local_cluster_gives_the_same_table(reference, tmp_path, chain_fmus):
    pytest.importorskip("distributed")
    import dask
    d, _, _ = reference
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = write_campaign(tmp_path)
    environment = dict(os.environ)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with local_cluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None) as cluster:
            s = run_campaign(camp, output=tmp_path / "out", scheduler=cluster.scheduler_address, progress=False)
    assert dict(os.environ) == environment      # the nannies' variables do not outlive the cluster
    assert (s.total, s.completed, s.failed) == (10, 6, 4)
    assert "Dask scheduler" in s.describe()
    got, ref = table(tmp_path / "out"), table(d / "out")
    # each run goes to a child process of the Dask worker: the crashing FMU costs its run only, with the
    # local pool's record ("worker process died with signal 6 (SIGABRT)"), not a KilledWorker
    crash = ref["param:src.mode"] == 3
    assert got[crash]["error"].str.contains("SIGABRT").all()
    same_tables(got, ref)


def test_dask_runs_are_killed_at_their_timeout(tmp_path, chain_fmus):
    pytest.importorskip("distributed")
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    camp = tmp_path / "slow.yaml"
    camp.write_text(SLOW.replace("param:gain.k: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]", "param:gain.k: [1, 2]")
                    .replace("step: 0.02", "step: 0.02\n  timeout: 0.5").replace("stop_time: 0.5", "stop_time: 600.0"))
    with local_cluster(n_workers=1, threads_per_worker=2, processes=True, host="127.0.0.1",
                       dashboard_address=None) as cluster:
        t0 = time.monotonic()
        s = run_campaign(camp, output=tmp_path / "out", scheduler=cluster.scheduler_address, progress=False)
        took = time.monotonic() - t0
    assert (s.total, s.failed) == (2, 2)
    assert table(tmp_path / "out")["error"].str.fullmatch(r"timed out after 0\.5 s \(worker killed\)").all()
    assert took < 60          # 600 s of simulated time, asleep 20 ms a 20 ms step, would take 600 s


def test_an_input_changed_while_the_campaign_runs_is_detected(tmp_path, chain_fmus):
    from master.campaign.execute import execute_run
    from master.campaign.runner import _changed_inputs, make_task
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    c = load_campaign(write_campaign(tmp_path))
    task = make_task(c, c.runs[0], tmp_path / "out")
    rec = execute_run(task)
    assert rec["outcome"] == "completed" and _changed_inputs(task["inputs"], rec["used"]) == []
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus, k=9.0)     # the scenario changes after the campaign hashed it
    rec = execute_run(task)
    assert _changed_inputs(task["inputs"], rec["used"]) == ["scenario file chain.ssp changed"]
    assert _changed_inputs({"fmus": {"a.fmu": "1"}}, {"fmus": ["2"]}) == ["an FMU changed"]
    assert _changed_inputs({"code_sha256": "a"}, {"code_sha256": "b"}) == ["cosim-master's code differs where the run ran"]
    assert _changed_inputs(task["inputs"], rec["used"]) == ["scenario file chain.ssp changed"]   # same code here
