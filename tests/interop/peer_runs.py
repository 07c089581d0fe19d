"""Run shipped SSPs in the peer masters (OMSimulator, Ecos, libcosim), each peer in a child process.

A peer runs FMUs in its own native code (and pythonfmu FMUs re-enter the interpreter): a crash or an abort there
must not take the test session with it, and OMSimulator's library must be loaded in the process that uses it.
``run_jobs(peer, jobs, folder)`` runs every job of one peer in one child and returns one DataFrame per job:
``time`` and ``"<component>.<variable>"`` after initialisation and after every step (tests/peers/*_runner.py say
what each peer does).  The child runs on one CPU (tests/peers/one_cpu.py: the same frames at a fraction of the CPU).

Where the peers are: ecospy and libcosimpy in the venv; OMSimulator in ``<repo>/../shared/omsimulator`` or
``$COSIM_OMSIMULATOR_LIB`` (tests/peers/omsimulator_runner.py); the SITL firmware in ``$ARDUPILOT_SITL`` or
``<repo>/../shared/sitl/arducopter``.  ``absent(peer)`` says why a peer cannot run here (None: it can).
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import pandas as pd

TESTS = Path(__file__).resolve().parents[1]
REPO = TESTS.parent
SSP_DIR = REPO / "ssp"
PEERS = ("omsimulator", "ecos", "libcosim")


@dataclass
class Job:
    ssp: str
    step: float
    n_steps: int
    variables: list                      # [component, variable, "Real" | "Integer"]
    set_strings: bool = False            # OMSimulator only: set the String parameters it drops (see its runner)
    options: dict = field(default_factory=dict)


def oms_lib() -> Path | None:
    sys.path.insert(0, str(TESTS))
    try:
        from peers.omsimulator_runner import omsimulator_lib
    finally:
        sys.path.remove(str(TESTS))
    return omsimulator_lib(REPO)


def sitl_binary() -> str | None:
    env = os.environ.get("ARDUPILOT_SITL")
    path = Path(env) if env else REPO.parent / "shared" / "sitl" / "arducopter"
    return str(path.resolve()) if path.is_file() and os.access(path, os.X_OK) else None


def absent(peer: str) -> str | None:
    """Why ``peer`` cannot run here, or None."""
    if peer == "omsimulator":
        return None if oms_lib() else "OMSimulator not found (../shared/omsimulator or $COSIM_OMSIMULATOR_LIB)"
    module = {"ecos": "ecospy", "libcosim": "libcosimpy"}[peer]
    if importlib.util.find_spec(module) is None:
        return f"{module} not installed"
    return None


_CHILD = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
from peers.one_cpu import pin
pin()                                   # before the peer's library loads (tests/peers/one_cpu.py says why)
peer, jobs, folder = sys.argv[2], json.loads(sys.argv[3]), sys.argv[4]
for i, job in enumerate(jobs):
    ssp, step, n, variables = job["ssp"], job["step"], job["n_steps"], [tuple(v) for v in job["variables"]]
    if peer == "omsimulator":
        from peers.omsimulator_runner import run_omsimulator
        df = run_omsimulator(ssp, step, n, [(c, v) for c, v, _ in variables], sys.argv[5],
                             set_strings=job["set_strings"])
    elif peer == "ecos":
        from peers.ecos_runner import run_ecos
        df = run_ecos(ssp, step, n, variables, job["options"].get("parameter_set", "scenario"))
    else:
        from peers.libcosim_runner import run_libcosim
        df = run_libcosim(ssp, step, n * step, [(c, v) for c, v, _ in variables])
    df.to_parquet(f"{folder}/{i}.parquet")
    print(f"job {i} done", flush=True)
"""


#: peers that step a run one step at a time and are never told where it ends (tests/peers/ecos_runner.py: ``init``
#: and ``step(1)``; tests/peers/libcosim_runner.py: ``step(1)``, no stop time to ``fmi2SetupExperiment``)
PREFIX_PEERS = ("ecos", "libcosim")


def _flight(peer: str, job: Job) -> tuple:
    """What a run of ``peer`` depends on, but for its length and the variables read (reads do not step anything)."""
    return str(Path(job.ssp).resolve()), job.step, job.options.get("parameter_set", "scenario") if peer == "ecos" else ""


def shared_flights(peer: str, jobs: list[Job]) -> tuple[list[Job], list[int]]:
    """The runs that give every job of ``peer`` (each the longest of its flight, recording the union of the
    variables) and, per job, the index of its run.  In a peer of ``PREFIX_PEERS`` the first n steps of a longer
    run are the calls that a run of n steps makes, as our FMUs read no stop time either (UavWind's
    ``setup_experiment`` keeps the start only; the others keep pythonfmu's, which does nothing): a job that is a
    prefix of a longer one is served from it.  Other peers (OMSimulator sets a stop time) run every job."""
    runs: list[Job] = []
    where: list[int] = []
    keys: dict = {}
    for job in jobs:
        key = _flight(peer, job) if peer in PREFIX_PEERS else len(runs)
        types = {(c, v): t for c, v, t in (runs[keys[key]].variables if key in keys else [])}
        if key in keys and all(types.get((c, v), t) == t for c, v, t in job.variables):
            run = runs[keys[key]]
            run.n_steps = max(run.n_steps, job.n_steps)
            run.variables += [list(v) for v in job.variables if (v[0], v[1]) not in types]
        else:
            keys[key] = len(runs)
            runs.append(Job(job.ssp, job.step, job.n_steps, [list(v) for v in job.variables], job.set_strings,
                            dict(job.options)))
        where.append(keys[key])
    return runs, where


def run_jobs(peer: str, jobs: list[Job], folder: Path, timeout: float = 900) -> list[pd.DataFrame]:
    """Every job in one child process of ``peer``; its DataFrames in the order of ``jobs`` (a job that is the
    beginning of a longer one is served from it, see ``shared_flights``)."""
    runs, where = shared_flights(peer, jobs)
    frames = _run_in_child(peer, runs, folder, timeout)
    return [frames[k].iloc[:job.n_steps + 1][["time", *(f"{c}.{v}" for c, v, _ in job.variables)]].copy()
            for job, k in zip(jobs, where)]


def _run_in_child(peer: str, jobs: list[Job], folder: Path, timeout: float) -> list[pd.DataFrame]:
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, TMPDIR=str(folder))          # OMSimulator and Ecos unpack into the temporary folder
    if sitl_binary():
        env.setdefault("ARDUPILOT_SITL", sitl_binary())
    env["COSIM_MASTER_OUTPUT"] = str(folder)            # the SITL FMU's working folders
    proc = subprocess.run([sys.executable, "-c", _CHILD, str(TESTS), peer, json.dumps([asdict(j) for j in jobs]),
                           str(folder), str(oms_lib() or "")],
                          capture_output=True, text=True, timeout=timeout, env=env, cwd=folder)
    if proc.returncode != 0 and "libtbb" in proc.stderr:
        import pytest
        pytest.skip("ecospy cannot load libtbb.so.12 (pip install tbb)")
    assert proc.returncode == 0, f"{peer} failed ({proc.returncode}):\n{proc.stdout[-1500:]}\n{proc.stderr[-3000:]}"
    return [pd.read_parquet(folder / f"{i}.parquet") for i in range(len(jobs))]
