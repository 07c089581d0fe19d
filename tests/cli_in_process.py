"""``cosim-master`` run in the test process: ``master.cli.main(argv)`` with its exit status, stdout and stderr, as
``subprocess.run`` would give them, without a new interpreter importing the program again (most of a short
command's CPU). For tests of what the command says and decides; a test of the process itself (signals, exit by
a signal, what a real program prints when it dies, tracebacks of an uncaught error) keeps the subprocess.

The command runs in ``cwd`` (given back afterwards) and its changes to the process are undone: the signal
handlers it installs, and the handler it puts on the engine's logger (which would hide the engine's warnings
from later tests' ``caplog``); the logger starts without handlers, as in a new process, so that its warnings
reach this command's stderr. A supervised ``run`` still simulates in a forked child, as the program does; the
output is taken at the file descriptors (1 and 2, and ``sys.stdout``/``sys.stderr`` on them, line-buffered), so
what that child or an FMU's C code writes is in ``stdout``/``stderr`` as it would be from the program
(append mode: writers sharing the file never overwrite each other).
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

_SIGNALS = [s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGXFSZ", None)) if s is not None]


@dataclass
class CliResult:
    returncode: int
    stdout: str
    stderr: str


def run_cli(args, cwd=None) -> CliResult:
    from master.cli import main

    argv = [str(a) for a in args]
    log = logging.getLogger("cosim_master")
    saved_log = (list(log.handlers), log.level, log.propagate)
    saved_signals = {s: signal.getsignal(s) for s in _SIGNALS}
    here = os.getcwd()
    with tempfile.TemporaryFile("a+", buffering=1) as out, tempfile.TemporaryFile("a+", buffering=1) as err:
        sys.stdout.flush()
        sys.stderr.flush()
        saved_fds = (os.dup(1), os.dup(2))
        try:
            os.dup2(out.fileno(), 1)
            os.dup2(err.fileno(), 2)
            if cwd is not None:
                os.chdir(Path(cwd))
            # as in a new process: the command puts its own handler on the engine's logger, writing to this
            # stderr (a handler an earlier in-process command left would write to that command's stderr)
            log.handlers[:] = []
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    code = main(argv)
                except SystemExit as exc:       # argparse: usage errors (2), --help and --version (0)
                    code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
                finally:
                    out.flush()
                    err.flush()
        finally:
            os.dup2(saved_fds[0], 1)
            os.dup2(saved_fds[1], 2)
            for fd in saved_fds:
                os.close(fd)
            os.chdir(here)
            for s, handler in saved_signals.items():
                signal.signal(s, handler)
            log.handlers[:] = saved_log[0]
            log.setLevel(saved_log[1])
            log.propagate = saved_log[2]
        out.seek(0)
        err.seek(0)
        return CliResult(int(code or 0), out.read(), err.read())
