"""One child process timed as a user's shell would time it: wall clock from start to exit, and the user + system
CPU of it and of everything it waited for (``getrusage(RUSAGE_CHILDREN)`` around it, as ``/usr/bin/time`` counts).
The benches that compare whole commands (start-up, recording, strategy C) share it."""
from __future__ import annotations

import resource
import subprocess
import time


def run_timed(cmd: list[str], **kwargs) -> tuple[subprocess.CompletedProcess, float, float]:
    """``subprocess.run(cmd, capture_output=True, text=True, **kwargs)`` and its (result, wall s, CPU s)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, **kwargs)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return proc, wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
