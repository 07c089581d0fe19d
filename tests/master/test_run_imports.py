"""What a run of a plain one-FMU SSP imports, in the supervising process and in its forked simulation process: not
pandas nor pyarrow.compute (~0.3 s in each process, for nothing a run needs), not importlib.metadata (the installed
packages' entry points: the SSD names no monitor) nor the UAV study, none of the algorithms it does not run."""
import subprocess
import sys

RUN = """
from master.ssp.writer import SspBuilder
b = SspBuilder("d")
b.add_component("d", {fmu!r})
ssp = b.write({tmp!r} + "/d.ssp")
from master.cli import main
for extra in ([], ["--no-supervise"]):
    code = main(["run", str(ssp), "--stop-time", "1", "--step", "0.1", "--record", "d.*", "-o",
                 {tmp!r} + "/out" + "".join(extra)] + extra)
    assert code == 0, code
"""


def test_a_run_imports_only_what_it_uses_in_either_process(tmp_path, reference_fmus):
    # -X importtime reports the imports of the forked simulation process too, on the same stderr
    fmu = reference_fmus / "fmi2" / "Dahlquist.fmu"
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", RUN.format(fmu=str(fmu), tmp=str(tmp_path))],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    imported = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines() if line.startswith("import time")}
    assert {"master.execution", "pyarrow.parquet", "master.algorithms.jacobi"} <= imported
    assert not {"pandas", "pyarrow.compute", "importlib.metadata", "uavstudy"} & imported
    # (gauss_seidel comes with the native step driver, which runs Jacobi and Gauss-Seidel)
    assert not {"master.algorithms.adaptive", "master.algorithms.ecco", "master.algorithms.iterative"} & imported
    assert (tmp_path / "out" / "results.csv").read_text() == (tmp_path / "out--no-supervise" / "results.csv").read_text()
