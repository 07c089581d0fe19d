"""``main`` shows the engine's warnings on stderr while it runs and then gives the logger back: called twice in
one process (a notebook, a test), a handler left behind wrote the second call's warnings to the first call's
stderr and kept them from the caller's own logging (``caplog`` saw nothing after any earlier ``main``)."""
import logging

from master.cli import main


def test_main_leaves_the_engine_logger_as_it_found_it(tmp_path, capsys):
    log = logging.getLogger("cosim_master")
    before = (list(log.handlers), log.level, log.propagate)
    assert main(["run", str(tmp_path / "missing.ssp"), "-o", str(tmp_path / "out")]) == 1
    assert "missing.ssp" in capsys.readouterr().err
    assert (list(log.handlers), log.level, log.propagate) == before

