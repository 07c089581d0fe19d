"""The campaign's fork server imports, before it forks any worker, the modules each installed scenario kind names in
``worker_modules`` (master/campaign/worker_preload.py): a worker forked from it does not import them in its first
run. A kind's module that does not import is skipped there (the run that needs it reports it)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from master.campaign import pool, worker_preload
from master.scenario_kinds import SCENARIO_KINDS, ScenarioKind

REPO = Path(__file__).resolve().parents[3]


class _Kind(ScenarioKind):
    name = "preload-test"

    def __init__(self, modules):
        self.worker_modules = tuple(modules)


def test_each_kinds_worker_modules_are_imported_and_a_broken_one_is_skipped(tmp_path, monkeypatch):
    (tmp_path / "preload_probe_ok.py").write_text("LOADED = True\n")
    (tmp_path / "preload_probe_broken.py").write_text("raise RuntimeError('broken on import')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in ("preload_probe_ok", "preload_probe_broken"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    SCENARIO_KINDS.register("preload-test", _Kind(["preload_probe_broken", "preload_probe_missing_xyz",
                                                   "preload_probe_ok"]))
    try:
        done = worker_preload.import_worker_modules()
    finally:
        SCENARIO_KINDS.unregister("preload-test")
    assert "preload_probe_ok" in done and sys.modules["preload_probe_ok"].LOADED
    assert "preload_probe_broken" not in done and "preload_probe_missing_xyz" not in done
    assert "preload_probe_broken" not in sys.modules


@pytest.mark.parametrize("server", [True, False])
def test_the_fork_servers_preload_imports_the_uav_kinds_run_modules_there_only(server):
    """What the server does with PRELOAD (forkserver.main: ``__import__`` each name but __main__), in a fresh
    interpreter with the environment the pool starts the server with: afterwards the UAV kind's build, scenario and
    monitor modules are there, so a worker forked from it has them before its first run. Without that environment
    (any other process importing the module) nothing of the study is imported."""
    code = ("import sys\nfrom master.campaign.pool import PRELOAD\n"
            "for m in PRELOAD:\n    if m != '__main__': __import__(m)\n"
            "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] == 'uavstudy')))\n")
    assert "master.campaign.worker_preload" in pool.PRELOAD
    env = {k: v for k, v in os.environ.items() if k != worker_preload.SERVER_FLAG}
    if server:
        env[worker_preload.SERVER_FLAG] = "1"
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    imported = set(out.stdout.split())
    if server:
        assert {"uavstudy.build", "uavstudy.scenario", "uavstudy.monitor"} <= imported
    else:
        assert not imported


def test_the_pool_starts_the_server_with_the_flag_and_leaves_its_own_environment_without(monkeypatch):
    seen = []
    monkeypatch.setattr(pool, "_ensure_server_running",
                        lambda *a: seen.append(os.environ.get(worker_preload.SERVER_FLAG)))
    assert pool._fork_server_started()
    assert seen == ["1"] and worker_preload.SERVER_FLAG not in os.environ
