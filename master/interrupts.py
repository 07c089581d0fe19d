"""Ctrl-C and SIGTERM held back while a run closes.

Closing a run writes its last block, terminates the FMUs and writes run.json. An interrupt in the middle left
results without their run.json, or a run.json that said "completed" beside a process that exited as failed.
Inside ``deferred()`` the signals are only noted; when the block ends each is delivered to the handler that
was in place before, so the interrupt still takes effect, just after the files are whole.
"""
from __future__ import annotations

import errno
import os
import signal
import sys
import threading
from contextlib import contextmanager

HELD = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def deferred():
    if threading.current_thread() is not threading.main_thread():     # only the main thread may set handlers
        yield
        return
    pending: list[int] = []
    previous = {s: signal.signal(s, lambda signum, frame: pending.append(signum)) for s in HELD}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        for s in dict.fromkeys(pending):
            signal.raise_signal(s)


# -- while the program starts ----------------------------------------------------------------------------------
# The command imports NumPy, pyarrow and the engine before it does anything. A KeyboardInterrupt raised inside
# an import gave a traceback, and inside NumPy's C extension NumPy's "your installation is broken" wall of text.
# Nothing has been written yet, so the program simply ends, with one line and the status of an interrupt.

def _exit_now(signum, frame):
    os.write(2, b"cosim-master: " + (b"interrupted\n" if signum == signal.SIGINT else b"stopped by SIGTERM\n"))
    os._exit(130 if signum == signal.SIGINT else 143)


def quiet_until_started() -> None:
    """Ctrl-C and SIGTERM end the program at once, quietly, until ``started()`` (main thread only)."""
    if threading.current_thread() is threading.main_thread():
        for s in HELD:
            signal.signal(s, _exit_now)


def started() -> None:
    """The command's modules are imported: Ctrl-C raises KeyboardInterrupt and SIGTERM has its default action
    again (the command installs its own handlers where it writes)."""
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is _exit_now:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGTERM) is _exit_now:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


# -- interrupts raised inside ctypes callbacks ----------------------------------------------------------------
# A native FMU calls the master's logger from inside doStep. A signal that arrived while the FMU ran (a Ctrl-C
# during a long doStep) has its Python handler run by the first bytecode after it: the logger callback. The
# KeyboardInterrupt raised there cannot cross the C frames, so ctypes prints "Exception ignored" and drops it,
# and the run carries on as if nobody had pressed Ctrl-C. ctypes reports the dropped exception through
# sys.unraisablehook, whichever line of the callback it came from. Sending the signal again does not help: the
# next bytecode may well be the same callback again (an FMU that sleeps, is interrupted and then logs). So the
# hook raises the interrupt itself at the first Python call or return of the main thread that is not inside a
# callback: once the C code has returned into the master.

_hook_installed = False
_NO_ROOM = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT}
_callback_codes: set = set()        # code objects the interrupt must not be raised in: callbacks, this hook


def _inside_callback(frame) -> bool:
    # C frames are not on the chain: a callback's frame links straight to the frame that made the foreign call
    while frame is not None:
        if frame.f_code in _callback_codes:
            return True
        frame = frame.f_back
    return False


def _raise_outside_callbacks(exc_type) -> None:
    previous = sys.getprofile()

    def at_next_call(frame, event, arg):
        if _inside_callback(frame):
            return
        sys.setprofile(previous)
        raise exc_type()
    sys.setprofile(at_next_call)


def _unraisable(previous):
    def hook(unraisable):
        exc_type = unraisable.exc_type
        if exc_type is not None and issubclass(exc_type, OSError) and \
                getattr(unraisable.exc_value, "errno", None) in _NO_ROOM:
            return      # a line of fmu.log that did not fit on a full disk: the results' write says so, once
        if (exc_type is None or not issubclass(exc_type, KeyboardInterrupt)
                or threading.current_thread() is not threading.main_thread()):
            previous(unraisable)
            return
        code = getattr(unraisable.object, "__code__", None)
        if code is not None:
            _callback_codes.add(code)
        _raise_outside_callbacks(exc_type)
    hook.previous = previous
    _callback_codes.add(hook.__code__)
    return hook


def keep_interrupts_from_callbacks() -> None:
    """Make an interrupt raised inside a ctypes callback take effect after the foreign call (idempotent)."""
    global _hook_installed
    if not _hook_installed:
        sys.unraisablehook = _unraisable(sys.unraisablehook)
        _hook_installed = True
