"""The engine's warnings reach the terminal as 'cosim-master: WARNING: ...' lines (as main writes them), in a
supervised run (given in its simulation process) as in an unsupervised one, although the command no longer imports
logging before a warning is given (``master.log``): the line format is installed on the logger's first use. A
fresh interpreter each, as a user's command starts."""
import subprocess
import sys

import pytest

from master.ssp.writer import SspBuilder

ENTRY = "import sys; from master.cli import entry; sys.exit(entry())"


@pytest.mark.parametrize("extra", [[], ["--no-supervise"]], ids=["supervised", "unsupervised"])
def test_a_warning_is_one_line_in_the_command_line_format(tmp_path, reference_fmus, extra):
    b = SspBuilder("feedthrough", stop=0.2, step=0.1)
    b.add_component("m", reference_fmus / "fmi2" / "Feedthrough.fmu")
    ssp = b.write(tmp_path / "feedthrough.ssp")
    (tmp_path / "in.csv").write_text("time,Int32_input,nothing_here\n0,1,2\n")
    proc = subprocess.run([sys.executable, "-c", ENTRY, "run", str(ssp), "-o", str(tmp_path / "out"), "--input",
                           str(tmp_path / "in.csv"), "--lenient", *extra], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert [ln for ln in lines if "nothing_here" in ln] == [
        f"cosim-master: WARNING: {tmp_path / 'in.csv'}: --input: ignoring column nothing_here, which names no "
        "input of m (--lenient)"], lines
