"""tests/cli_in_process.py gives what the program would: exit status, stdout, and on stderr the engine's warnings
and what a forked child writes; the process is left as it was (signal handlers, the engine's logger, cwd)."""
import io
import logging
import os
import signal

import master.cli as cli
from cli_in_process import run_cli


def test_the_command_in_process_says_what_the_program_says_and_leaves_the_process_as_it_was(tmp_path, monkeypatch):
    def dispatch(args):
        logging.getLogger("cosim_master").warning("a warning of the engine")
        pid = os.fork()
        if pid == 0:                    # a supervised run's child writes to the file descriptor it inherited
            os.write(2, b"from the child\n")
            os._exit(0)
        os.waitpid(pid, 0)
        print("on stdout", os.getcwd() == str(tmp_path))
        signal.signal(signal.SIGTERM, lambda *a: None)      # as `run` and `campaign` install theirs
        return 3
    monkeypatch.setattr(cli, "_dispatch", dispatch)
    log = logging.getLogger("cosim_master")
    earlier = logging.StreamHandler(io.StringIO())         # what an earlier command in this process left
    monkeypatch.setattr(log, "handlers", [earlier])
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    here = os.getcwd()
    r = run_cli(["inspect", "x.ssp"], cwd=tmp_path)
    assert r.returncode == 3 and r.stdout == "on stdout True\n"
    assert "cosim-master: WARNING: a warning of the engine" in r.stderr and "from the child" in r.stderr, r.stderr
    assert earlier.stream.getvalue() == ""
    assert log.handlers == [earlier] and os.getcwd() == here
    assert {s: signal.getsignal(s) for s in handlers} == handlers


def test_usage_errors_exit_2_with_argparse_s_line():
    r = run_cli(["bogus"])
    assert r.returncode == 2 and "invalid choice: 'bogus'" in r.stderr and r.stdout == ""
