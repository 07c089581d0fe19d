"""The program loads NumPy with OpenBLAS on one thread (its threads per core spun at every start), unless the user
chose a number; the choice is this process's alone: what it starts later does not inherit it."""
import os
import subprocess
import sys

import pytest

PROBE = """
import os, subprocess, sys
from master.cli import _numpy_single_threaded
_numpy_single_threaded()
import numpy
threads = len(os.listdir("/proc/self/task"))
inherited = subprocess.run([sys.executable, "-c", "import os; print(os.environ.get('OPENBLAS_NUM_THREADS'))"],
                           capture_output=True, text=True).stdout.strip()
print(threads, os.environ.get("OPENBLAS_NUM_THREADS"), inherited)
"""

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads in /proc (Linux)")


def _probe(**env):
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, env=dict(base, **env),
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_numpy_gets_one_blas_thread_and_nothing_started_later_inherits_the_choice():
    assert _probe() == ["1", "None", "None"]


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS takes one thread on one core anyway")
def test_the_users_choice_stands():
    threads, mine, inherited = _probe(OPENBLAS_NUM_THREADS="2")
    assert (threads, mine, inherited) == ("2", "2", "2")
