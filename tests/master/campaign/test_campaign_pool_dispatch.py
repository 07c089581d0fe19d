"""The local pool hands a worker its next task before the parent books the finished record (the record's
fsync'ed write would keep the worker idle), and a pool started before the tasks are known (run_campaign
starts it while it plans) uses, replaces or stops its early workers."""
import multiprocessing as mp

import pytest

import master.campaign.pool as pool_mod
from campaign_helpers import write_chain_ssp
from master.campaign.pool import WorkerPool
from master.campaign.runner import make_task
from master.campaign.spec import load_campaign

CAMPAIGN = """\
name: dispatch
seed: 5
repetitions: 1
scenario: chain.ssp
grid:
  param:gain.k: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
run:
  stop_time: 0.5
  step: 0.1
"""


@pytest.fixture()
def tasks(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
    (tmp_path / "campaign.yaml").write_text(CAMPAIGN)
    camp = load_campaign(tmp_path / "campaign.yaml")
    return [make_task(camp, r, tmp_path / "out") for r in camp.runs]


def _logged_sends(monkeypatch):
    sent = []
    real = pool_mod._Worker.send

    def send(self, task):
        sent.append(task["run_id"])
        return real(self, task)
    monkeypatch.setattr(pool_mod._Worker, "send", send)
    return sent


def test_the_next_task_is_sent_before_the_record_is_booked(tasks, monkeypatch):
    sent = _logged_sends(monkeypatch)
    seen = []

    def on_result(rec):
        assert rec["outcome"] == "completed", rec.get("error")
        seen.append((rec["run_id"], len(sent)))

    WorkerPool(2).run(tasks, on_result)
    assert sorted(r for r, _ in seen) == sorted(t["run_id"] for t in tasks)
    # at the k-th record, the two first tasks and one more per record so far have gone out (capped by the queue)
    assert [n for _, n in seen] == [min(len(tasks), 2 + k) for k in range(1, len(tasks) + 1)]
    assert sent == [t["run_id"] for t in tasks]        # in the campaign's order


# early workers are spawned ones: a fork server imports the master from the pool's creation on instead

def test_early_workers_run_the_tasks_and_the_spare_ones_stop(tasks):
    p = WorkerPool(2, start_method="spawn")     # one more worker than tasks: a spare
    p.start()
    early = list(p._ready)
    assert len(early) == 2 and all(w.proc.is_alive() for w in early)
    got = []
    p.run(tasks[:1], got.append)
    assert sorted(r["run_id"] for r in got) == sorted(t["run_id"] for t in tasks[:1])
    assert all(r["outcome"] == "completed" for r in got)
    assert p.started_workers == 2           # the early one did the work: nobody else was started
    assert not p._ready and not any(w.proc.is_alive() for w in early)
    assert not mp.active_children()


def test_an_early_worker_that_died_is_replaced_without_blaming_a_task(tasks):
    p = WorkerPool(1, start_method="spawn")
    p.start()
    dead = p._ready[0]
    dead.proc.kill()
    dead.proc.join(5)
    got = []
    p.run(tasks[:2], got.append)
    assert sorted(r["run_id"] for r in got) == sorted(t["run_id"] for t in tasks[:2])
    assert all(r["outcome"] == "completed" for r in got), [r.get("error") for r in got]
    assert p.crashes == 0 and p.started_workers == 2


def test_close_stops_early_workers_no_run_took():
    p = WorkerPool(2, start_method="spawn")
    p.start()
    procs = [w.proc for w in p._ready]
    p.close()
    assert not any(proc.is_alive() for proc in procs)


def test_a_worker_without_more_work_is_let_go_before_the_last_record(tasks, monkeypatch):
    asked = []
    real = pool_mod._Worker.ask_to_stop

    def ask_to_stop(self):
        asked.append(self.proc.name)
        return real(self)
    monkeypatch.setattr(pool_mod._Worker, "ask_to_stop", ask_to_stop)
    booked = []
    p = WorkerPool(2)
    p.run(tasks[:3], lambda rec: booked.append(len(asked)), wait=False)
    # the worker that finished first while the queue was empty exits during the other's last run
    assert booked == [0, 1, 2]      # let go at its own record, before the third run reported
    procs = [w.proc for w in p._leaving]
    assert len(procs) == 2
    p.close()
    assert not p._leaving and not any(proc.is_alive() for proc in procs)
    assert not mp.active_children()


def test_forked_workers_run_with_the_environment_of_their_start(tasks, tmp_path, monkeypatch):
    """Workers are forked from a fork server started once per process (with the environment of that moment); each
    worker takes the caller's environment as it is when the worker starts, as a spawned one would: here the FMU
    cache folder set after the server started is the one the run unpacks its FMUs into."""
    first = WorkerPool(1)
    assert first.ctx.get_start_method() == "forkserver"
    got = []
    first.run(tasks[:1], got.append)            # the server runs from here on
    cache = tmp_path / "fmu-cache"
    monkeypatch.setenv("COSIM_MASTER_CACHE", str(cache))
    WorkerPool(1).run(tasks[1:2], got.append)
    assert [r["outcome"] for r in got] == ["completed", "completed"], [r.get("error") for r in got]
    assert cache.is_dir() and any(cache.rglob("modelDescription.xml"))
    assert not mp.active_children()
