"""One child process per peer for the UAV interop tests of every module selected (``uav_peer_runs``).

Each module that runs the shipped UAV SSPs in a peer defines ``uav_peer_jobs(peer, tmp_path_factory)``: its jobs
for that peer, ``{key: peer_runs.Job}``.  The first test asking for a peer's runs starts one child
(``peer_runs.run_jobs``) with the jobs of every selected module, in module order, and every module gets its own
frames back by its keys.  A child costs ~0.5 s CPU to start and import pandas and the peer, and its first model
imports and compiles our FMUs' Python (bench/results/test_suite_2026-11-29_peers.md): one per peer instead of one
per module.  The runs themselves are as before; a peer that fails now fails the tests of every module using it.
"""
from __future__ import annotations

import pytest
from peer_runs import run_jobs


@pytest.fixture(scope="session")
def uav_peer_runs(request, tmp_path_factory):
    """``runs_of(peer, module)``: the frames of ``module``'s jobs for ``peer`` ({key: DataFrame})."""
    done: dict = {}

    def runs_of(peer: str, module) -> dict:
        if peer not in done:
            modules = []
            for item in request.session.items:
                m = getattr(item, "module", None)
                if m is not None and hasattr(m, "uav_peer_jobs") and m not in modules:
                    modules.append(m)
            if module not in modules:
                modules.append(module)
            jobs = {(m.__name__, key): job for m in modules
                    for key, job in m.uav_peer_jobs(peer, tmp_path_factory).items()}
            frames = run_jobs(peer, list(jobs.values()), tmp_path_factory.mktemp(f"uav_{peer}"))
            done[peer] = dict(zip(jobs, frames))
        return {key: frame for (name, key), frame in done[peer].items() if name == module.__name__}

    return runs_of
