"""The end of a supervised run. The child's last message says how it is about to exit; the supervisor writes
run.json and settles the output folder while the kernel tears the child's process down, then reaps it, and
rewrites run.json when the child's real exit differs from the announced one (a crash in its teardown)."""
import json
import os
import signal

from master.ssp.writer import SspBuilder
from master.supervise import run_supervised


def _dahlquist(tmp_path, reference_fmus):
    b = SspBuilder("d")
    b.add_component("d", reference_fmus / "fmi2" / "Dahlquist.fmu")
    return b.write(tmp_path / "d.ssp")


def test_a_child_that_announces_success_then_dies_by_a_signal_is_recorded_so(tmp_path, reference_fmus, monkeypatch):
    ssp = _dahlquist(tmp_path, reference_fmus)
    test_process = os.getpid()
    real_exit = os._exit

    def dies_in_teardown(status):
        if os.getpid() != test_process:     # the forked simulation process, after its last message
            os.kill(os.getpid(), signal.SIGKILL)
        real_exit(status)
    monkeypatch.setattr(os, "_exit", dies_in_teardown)
    out = tmp_path / "out"
    result = run_supervised(ssp, stop_time=1.0, step=0.1, output=str(out), record=["d.x"])
    meta = json.loads((out / "run.json").read_text())
    # the simulation had completed and said so; its process then died: both are on record, as with a child
    # whose exit the supervisor waited for before it wrote anything
    assert meta["outcome"] == "completed"
    assert meta["supervised"] == {"child_exit": -signal.SIGKILL}
    assert result.metadata["supervised"] == {"child_exit": -signal.SIGKILL}
    assert meta["rows_recorded"] == 11
    assert "run.json" in meta["products"] and not (out / ".cosim-master.stack").exists()


def test_a_child_that_exits_as_announced_leaves_run_json_as_first_written(tmp_path, reference_fmus):
    ssp = _dahlquist(tmp_path, reference_fmus)
    out = tmp_path / "out"
    result = run_supervised(ssp, stop_time=1.0, step=0.1, output=str(out), record=["d.x"])
    meta = json.loads((out / "run.json").read_text())
    assert meta["outcome"] == "completed" and meta["supervised"] == {"child_exit": 0}
    assert result.metadata == meta
    # the platform's name, asked by the supervisor while it waits for its child, is the one this interpreter gives
    import platform
    assert meta["platform"] == platform.platform()


def test_a_rerun_into_the_folder_replaces_the_earlier_run_while_the_child_ends(tmp_path, reference_fmus):
    """The folder is settled before the child is reaped: the earlier run's products are gone, the new ones in
    place, and the earlier run set aside is gone (the lock file stays, as it always has)."""
    ssp = _dahlquist(tmp_path, reference_fmus)
    out = tmp_path / "out"
    run_supervised(ssp, stop_time=1.0, step=0.1, output=str(out), record=["d.x"])
    (out / "results.csv").write_text("earlier\n")
    run_supervised(ssp, stop_time=2.0, step=0.1, output=str(out), record=["d.x"])
    meta = json.loads((out / "run.json").read_text())
    assert meta["rows_recorded"] == 21
    assert len((out / "results.csv").read_text().splitlines()) == 22
    from master.results import LOCK_NAME
    assert sorted(p.name for p in out.iterdir() if p.name != LOCK_NAME) == sorted(meta["products"])


def test_an_api_callers_objects_are_not_frozen(tmp_path, reference_fmus):
    """The supervisor freezes what it imports after the fork (``gc.freeze``) only in the CLI's own process: a
    caller's process (this test's) keeps every object collectable."""
    import gc
    ssp = _dahlquist(tmp_path, reference_fmus)
    frozen, collecting = gc.get_freeze_count(), gc.isenabled()
    run_supervised(ssp, stop_time=1.0, step=0.1, output=str(tmp_path / "out"), record=["d.x"])
    assert (gc.get_freeze_count(), gc.isenabled()) == (frozen, collecting)
