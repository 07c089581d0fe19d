"""Once ``entry()`` has its exit code, a Ctrl-C or a SIGTERM while the interpreter shuts down (which resets the
handlers) must not turn the exit into a death by signal: a run that completed and then got a late SIGTERM
exited -15 instead of 0 (tests/master/test_faults.py's random interrupts met it once recording got faster)."""
import gc
import signal

import master.cli as cli


def test_late_interrupts_are_ignored_once_the_exit_code_is_decided(monkeypatch):
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    collecting = gc.isenabled()     # entry() turns the collector off until the command's imports (main's, mocked)
    monkeypatch.setattr(cli, "main", lambda argv=None, **options: 0)
    try:
        assert cli.entry() == 0
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
        if collecting:
            gc.enable()
