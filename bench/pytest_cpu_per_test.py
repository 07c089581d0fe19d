"""A pytest plugin (``-p pytest_cpu_per_test`` with ``bench/`` on PYTHONPATH) that measures the CPU time of
every test: user + system of the pytest process and of the child processes reaped during the test
(``resource.getrusage`` RUSAGE_SELF + RUSAGE_CHILDREN), from the start of its setup to the end of its teardown,
so a module- or session-scoped fixture is charged to the test that first needs it. A child that is reaped
later (a daemon, a pool that outlives the test) is charged to the test during which it is reaped.

Writes one line per test, ``CPU_S<TAB>nodeid``, to the file named by ``COSIM_TEST_CPU_FILE``
(bench/bench_test_suite.py reads it).
"""
from __future__ import annotations

import os
import resource

import pytest

_lines: list[str] = []


def _cpu() -> float:
    s = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    t0 = _cpu()
    yield
    _lines.append(f"{_cpu() - t0:.4f}\t{item.nodeid}\n")


def pytest_sessionfinish(session, exitstatus):
    target = os.environ.get("COSIM_TEST_CPU_FILE")
    if target and _lines:
        with open(target, "a", encoding="utf-8") as f:
            f.writelines(_lines)
