"""What a run of a plain one-FMU SSP imports, in the supervising process and in its forked simulation process: not
pandas nor pyarrow.compute (~0.3 s in each process, for nothing a run needs), not importlib.metadata (the installed
packages' entry points: the SSD names no monitor) nor the UAV study, none of the algorithms it does not run, not the
SSP writer (bare FMUs only), the input tables' reader nor the in-process pythonfmu slave. And what the simulation
process, whose start is the run's, does not do: ask the platform's name (``uname -p`` in a subprocess), which its
parent does for run.json when it would otherwise wait for the child, nor import pyarrow (~40 ms): it records into
shared memory and names its columns as plain data; its parent, which writes the files, imports pyarrow and the
sinks meanwhile."""
import json
import platform
import subprocess
import sys

from master.ssp.writer import SspBuilder

RUN = """
import os, sys
parent = os.getpid()

def note_subprocesses_and_imports(event, args):
    if event == "subprocess.Popen":
        os.write(2, f"spawned {{'parent' if os.getpid() == parent else 'child'}} {{args[0]}}\\n".encode())  # whole
    elif event == "import" and os.getpid() != parent:
        os.write(2, f"child imports {{args[0]}} {{'pyarrow' in sys.modules}}\\n".encode())   # one line, whole
sys.addaudithook(note_subprocesses_and_imports)
os.register_at_fork(before=lambda: os.write(2, f"forks with {{sorted({{'dataclasses', 'json', 'logging', 'multiprocessing', 'socket'}} & set(sys.modules))}}\\n".encode()))
from master.cli import main
for extra in ([], ["--no-supervise"]):
    code = main(["run", {ssp!r}, "--stop-time", "1", "--step", "0.1", "--record", "d.*", "-o",
                 {tmp!r} + "/out" + "".join(extra)] + extra)
    assert code == 0, code
"""


def test_a_run_imports_only_what_it_uses_in_either_process(tmp_path, reference_fmus):
    # -X importtime reports the imports of the forked simulation process too, on the same stderr
    b = SspBuilder("d")
    b.add_component("d", reference_fmus / "fmi2" / "Dahlquist.fmu")
    ssp = b.write(tmp_path / "d.ssp")
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", RUN.format(ssp=str(ssp), tmp=str(tmp_path))],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    imported = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines() if line.startswith("import time")}
    assert {"master.execution", "pyarrow.parquet", "master.algorithms.jacobi"} <= imported
    assert not {"pandas", "pyarrow.compute", "importlib.metadata", "uavstudy", "master.ssp.writer"} & imported
    assert not {"master.fmi.table", "master.fmi.inprocess"} & imported
    # the supervisor forks its child and talks to it over pipes itself (~4 ms of multiprocessing and socket before
    # the fork); json is run.json's, written by the supervisor after the fork; logging is imported by the first
    # warning (master.log), and this run has none
    assert "multiprocessing" not in imported
    forks = [line for line in proc.stderr.splitlines() if line.startswith("forks with ")]
    assert forks[0] == "forks with []", forks
    # (gauss_seidel comes with the native step driver, which runs Jacobi and Gauss-Seidel)
    assert not {"master.algorithms.adaptive", "master.algorithms.ecco", "master.algorithms.iterative"} & imported
    assert (tmp_path / "out" / "results.csv").read_text() == (tmp_path / "out--no-supervise" / "results.csv").read_text()
    spawned = [line.split()[1:] for line in proc.stderr.splitlines() if line.startswith("spawned ")]
    assert ["parent", "uname"] in spawned          # the platform's name is asked, by the supervising process
    assert not [who for who, program in spawned if who == "child" and program == "uname"]
    # (module imported, whether pyarrow is loaded then: inherited from the parent or imported by the child)
    child_imports = [line.split()[2:] for line in proc.stderr.splitlines() if line.startswith("child imports ")]
    assert ["fmpy", "False"] in child_imports       # fmpy is the child's own import (not made before the fork)
    assert not [m for m, loaded in child_imports if loaded == "True" or m.startswith("master.sinks.")]
    assert "logging" not in [m for m, _ in child_imports]
    assert "dataclasses" not in [m for m, _ in child_imports]     # no dataclass left to define (see below)
    for out in ("out", "out--no-supervise"):
        assert json.loads((tmp_path / out / "run.json").read_text())["platform"] == platform.platform()


#: the dataclasses a run of one FMU defines: none. Python 3.11 compiles each generated method of a dataclass from
#: source with its own ``exec`` in every process (~3 M instructions a class, ~0.4 % of a short run's start-up
#: each); the run path's records are plain classes (``master.records.Record``) or named tuples, the last being
#: ``plan.model.Var`` and the SSP model's (bench/results/startup_2026-11-29b.md, "ssp6").
RUN_PATH_DATACLASSES = set()

DATACLASSES = """
import dataclasses, sys
from master.cli import main
assert main(["run", {ssp!r}, "--stop-time", "1", "--step", "0.1", "-o", {out!r}, "--no-supervise"]) == 0
print(sorted(f"{{m}}.{{n}}" for m, mod in list(sys.modules.items()) if m.startswith("master.")
             for n, o in vars(mod).items() if isinstance(o, type) and dataclasses.is_dataclass(o) and o.__module__ == m))
"""


def test_a_run_defines_no_dataclass_beyond_the_known_ones(tmp_path, reference_fmus):
    # a fresh interpreter: what one run imports, the modules of both processes of a supervised run
    b = SspBuilder("d")
    b.add_component("d", reference_fmus / "fmi2" / "Dahlquist.fmu")
    ssp = b.write(tmp_path / "d.ssp")
    proc = subprocess.run([sys.executable, "-c", DATACLASSES.format(ssp=str(ssp), out=str(tmp_path / "out"))],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    defined = set(eval(proc.stdout.splitlines()[-1]))      # noqa: S307 - a list of names printed above
    assert "master.execution.Options" not in defined and "master.settings.Settings" not in defined
    assert defined == RUN_PATH_DATACLASSES
