"""A pytest plugin (``-p pytest_cpu_per_test`` with ``bench/`` on PYTHONPATH) that measures the CPU time of
every test: user + system of the pytest process and of the child processes reaped during the test
(``resource.getrusage`` RUSAGE_SELF + RUSAGE_CHILDREN), from the start of its setup to the end of its teardown,
so a module- or session-scoped fixture is charged to the test that first needs it. A child that is reaped
later (a daemon, a pool that outlives the test) is charged to the test during which it is reaped.

Writes one line per test, ``CPU_S<TAB>nodeid``, to the file named by ``COSIM_TEST_CPU_FILE``
(bench/bench_test_suite.py reads it), and ``USER_S<TAB>SYSTEM_S<TAB>nodeid`` to ``COSIM_TEST_CPU_SPLIT_FILE`` if it
is set (to tell which tests pay system time: forks, page faults, thread hand-offs).
"""
from __future__ import annotations

import os
import resource

import pytest

_lines: list[str] = []
_split: list[str] = []


def _cpu() -> tuple[float, float]:
    s = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + c.ru_utime, s.ru_stime + c.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    u0, s0 = _cpu()
    yield
    u1, s1 = _cpu()
    _lines.append(f"{u1 - u0 + s1 - s0:.4f}\t{item.nodeid}\n")
    _split.append(f"{u1 - u0:.4f}\t{s1 - s0:.4f}\t{item.nodeid}\n")


def pytest_sessionfinish(session, exitstatus):
    target = os.environ.get("COSIM_TEST_CPU_FILE")
    if target and _lines:
        with open(target, "a", encoding="utf-8") as f:
            f.writelines(_lines)
    split = os.environ.get("COSIM_TEST_CPU_SPLIT_FILE")
    if split and _split:
        with open(split, "a", encoding="utf-8") as f:
            f.writelines(_split)
