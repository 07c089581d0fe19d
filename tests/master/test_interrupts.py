"""Ctrl-C while a run closes is held until its files are whole, then delivered (master/interrupts.py)."""
from __future__ import annotations

import os
import signal

import pytest

from master import interrupts


def test_an_interrupt_inside_is_delivered_after_the_block():
    before = signal.getsignal(signal.SIGINT)
    if before is not signal.default_int_handler:
        pytest.skip("this process handles SIGINT itself")
    done = []
    with pytest.raises(KeyboardInterrupt):
        with interrupts.deferred():
            os.kill(os.getpid(), signal.SIGINT)
            done.append("the rest of the block ran")
    assert done == ["the rest of the block ran"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler      # the handler is back


def test_without_an_interrupt_nothing_happens():
    before = signal.getsignal(signal.SIGINT)
    with interrupts.deferred():
        pass
    assert signal.getsignal(signal.SIGINT) is before


def _qsort_calling(compare):
    import ctypes
    libc = ctypes.CDLL("libc.so.6")
    cmp_type = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))
    values = (ctypes.c_int * 8)(5, 3, 7, 1, 8, 2, 6, 4)
    libc.qsort(values, len(values), ctypes.sizeof(ctypes.c_int), cmp_type(compare))
    return list(values)


def test_an_interrupt_inside_a_ctypes_callback_reaches_the_caller_after_the_foreign_call(monkeypatch):
    """libc's qsort stands in for an FMU calling the master's logger: the first comparison is where a pending
    Ctrl-C's handler runs. ctypes alone prints the KeyboardInterrupt and drops it, and qsort finishes."""
    import sys
    import time
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("this process handles SIGINT itself")
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)     # the hook is undone after the test
    monkeypatch.setattr(interrupts, "_hook_installed", False)
    interrupts.keep_interrupts_from_callbacks()
    calls = []

    def compare(a, b):
        calls.append(1)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)      # its handler runs inside this callback
        return a[0] - b[0]
    with pytest.raises(KeyboardInterrupt) as caught:
        _qsort_calling(compare)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            time.sleep(0.01)
    assert len(calls) > 1                   # qsort went on: ctypes had dropped the interrupt in the callback
    assert "compare" not in [entry.name for entry in caught.traceback]     # raised again outside it


def test_other_exceptions_in_callbacks_still_go_to_the_previous_hook(monkeypatch):
    import sys
    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.exc_type))
    monkeypatch.setattr(interrupts, "_hook_installed", False)
    interrupts.keep_interrupts_from_callbacks()
    interrupts.keep_interrupts_from_callbacks()          # idempotent: one hook, not two

    def compare(a, b):
        raise ValueError("a bug in a callback")
    _qsort_calling(compare)
    assert seen and set(seen) == {ValueError}
    assert sys.unraisablehook.previous.__name__ == "<lambda>"


# -- while the program starts ---------------------------------------------------------------------------------
def _handles(pid: int, sig: int) -> bool:
    """The process has a handler of its own for ``sig`` (/proc/PID/status SigCgt)."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("SigCgt:"):
                return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    except OSError:
        pass
    return False


def _shell_signals():
    """The child as a shell starts it: SIGINT and SIGTERM neither ignored nor blocked, whatever a test runner's
    worker inherited."""
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})


def test_the_command_module_imports_no_numpy():
    """entry() takes Ctrl-C before NumPy loads only if importing master.cli does not load it first."""
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-c", "import sys, master.cli; print(sorted(m for m in ('numpy', 'pyarrow', "
                        "'pandas') if m in sys.modules))"], capture_output=True, text=True, timeout=60)
    assert r.stdout.strip() == "[]", r.stdout + r.stderr


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs /proc to see the handlers")
@pytest.mark.parametrize("sig,code,said", [(signal.SIGINT, 130, "interrupted"),
                                           (signal.SIGTERM, 143, "stopped by SIGTERM")])
def test_an_interrupt_while_the_program_starts_is_one_line(tmp_path, test_fmus, sig, code, said):
    """issue 25: Ctrl-C in the first seconds of `run` (its imports) gave a traceback, once NumPy's "bad install"
    wall of text; SIGTERM killed it without a word. Sent to the process group (as a terminal's Ctrl-C) at points
    from the moment entry() has its start-up handler (the process catches SIGTERM) into the run itself: every
    one ends with one line and the interrupt's exit status. The delays are where, not a timing assertion."""
    import subprocess
    import sys
    import time
    from pathlib import Path

    import master
    from master.ssp.writer import SspBuilder
    # long enough to be running at the last delay on any machine: a faster start-up finished 40 s in under 0.8 s
    b = SspBuilder("long", stop=1000.0, step=1e-4)
    b.add_component("I1", test_fmus["c2:Integrator"], params={"a": 0.0, "x0": 1.0})
    b.add_component("I2", test_fmus["c2:Integrator"], params={"a": -0.01, "x0": 0.0})
    b.connect("I1", "y", "I2", "u")
    b.connect("I2", "y", "I1", "u")
    ssp = b.write(tmp_path / "long.ssp")
    env = dict(os.environ, PYTHONPATH=str(Path(master.__file__).parents[1]))
    outcomes = []
    for k, delay in enumerate((0.0, 0.01, 0.03, 0.06, 0.1, 0.2, 0.4, 0.8)):
        p = subprocess.Popen([sys.executable, "-m", "master.cli", "run", str(ssp), "-o", str(tmp_path / f"o{k}"),
                              "--no-progress"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True, preexec_fn=_shell_signals)
        deadline = time.monotonic() + 60
        while not _handles(p.pid, signal.SIGTERM) and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.001)
        time.sleep(delay)
        os.killpg(p.pid, sig)
        _, err = p.communicate(timeout=120)
        outcomes.append((delay, p.returncode, err))
        assert p.returncode == code, outcomes[-1]
        assert err.startswith("cosim-master: ") and said in err and "Traceback" not in err, outcomes[-1]
        assert "\n" not in err.strip(), outcomes[-1]
