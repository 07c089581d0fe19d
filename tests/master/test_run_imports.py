"""What a run of a plain one-FMU SSP imports, in the supervising process and in its forked simulation process: not
pandas nor pyarrow.compute (~0.3 s in each process, for nothing a run needs), not importlib.metadata (the installed
packages' entry points: the SSD names no monitor) nor the UAV study, none of the algorithms it does not run, not the
SSP writer (bare FMUs only). And what the simulation process, whose start is the run's, does not do: ask the
platform's name (``uname -p`` in a subprocess), which its parent does for run.json while the child starts."""
import json
import platform
import subprocess
import sys

from master.ssp.writer import SspBuilder

RUN = """
import os, sys
parent = os.getpid()

def note_subprocesses(event, args):
    if event == "subprocess.Popen":
        print(f"spawned {{'parent' if os.getpid() == parent else 'child'}} {{args[0]}}", file=sys.stderr, flush=True)
sys.addaudithook(note_subprocesses)
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
    # (gauss_seidel comes with the native step driver, which runs Jacobi and Gauss-Seidel)
    assert not {"master.algorithms.adaptive", "master.algorithms.ecco", "master.algorithms.iterative"} & imported
    assert (tmp_path / "out" / "results.csv").read_text() == (tmp_path / "out--no-supervise" / "results.csv").read_text()
    spawned = [line.split()[1:] for line in proc.stderr.splitlines() if line.startswith("spawned ")]
    assert ["parent", "uname"] in spawned          # the platform's name is asked, by the supervising process
    assert not [who for who, program in spawned if who == "child" and program == "uname"]
    for out in ("out", "out--no-supervise"):
        assert json.loads((tmp_path / out / "run.json").read_text())["platform"] == platform.platform()
