"""Jacobi with the doSteps of one master step run concurrently (the ``threads`` setting).

Under Jacobi no component reads a value produced in the same step, so the components' doSteps are independent:
each component's transfers, input setters and doStep run as one task, ``threads`` at a time (the stepping
thread runs its share of the tasks itself), and the step joins all tasks before it reads any output. The outputs are
then read, and staged outputs published, in component order on the stepping thread, exactly as the sequential
step does, so the results are bit-identical to ``threads=1``.

Statuses and exceptions are handled after the join, in component order: the first component whose setter or
doStep failed is the one the one-line error names (as in the sequential step, where later components would
not have stepped; here they did, which only shows in run.json's ``do_step_calls``), and a component asking to
terminate ends the run after this step. FMU log messages of concurrent components may interleave in any order.

Only doSteps that release the GIL overlap: native FMUs (their doStep is called through ctypes.CDLL here, not
the PyDLL view the sequential step uses) and pythonfmu FMUs whose doStep waits in C without the GIL (the SITL
vehicle's lockstep loop). A pure-Python doStep holds the GIL and gains nothing.

The pool is made on the first step, in the process that steps (after a supervisor's fork), and shut down by
``Algorithm.finish``.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor, wait


class StepPool:
    """``threads - 1`` worker threads, created when first used."""

    def __init__(self, threads: int):
        self.threads = threads
        self._pool = None

    def map_ordered(self, tasks, t):
        """Run ``task(t)`` for every task; returns each one's (result, exception), in task order, once all
        have finished. Task k runs on thread k mod ``threads`` (thread 0 is this one), so that every thread
        has its share when there are more tasks than threads."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.threads - 1, thread_name_prefix="cosim-step")
        n = self.threads
        futures = [self._pool.submit(_run_all, tasks[g::n], t) for g in range(1, min(n, len(tasks)))]
        try:
            mine = _run_all(tasks[0::n], t)
        finally:
            # also on Ctrl-C in this thread's own tasks: the others finish their doSteps before the run closes
            # the instances they are using
            wait(futures)
        groups = [mine] + [f.result() for f in futures]
        return [groups[k % n][k // n] for k in range(len(tasks))]

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None


def _run_all(tasks, t):
    out = []
    for task in tasks:
        try:
            out.append((task(t), None))
        except Exception as exc:        # reported after the join, in component order
            out.append((None, exc))
    return out


def compile_parallel_step(rt, order: list[int], h: float, pool: StepPool):
    """The Jacobi step of the active components in ``order`` with concurrent doSteps (see the module doc)."""
    from .compiled import _failer, _step_failer
    fail, step_failed, calls = _failer(rt), _step_failer(rt), rt.do_step_calls
    comps = []
    for i in (i for i in order if rt.active[i]):
        k = rt.multiple[i]
        transfers, setters, _, getters, publish = rt.fast_ops(i)
        comps.append((i, k, _task(i, h * k, transfers, setters, rt.slaves[i].bound_step(), calls), getters,
                      publish))

    def step(n, t):
        due = [c for c in comps if n % c[1] == 0]
        if due:
            tasks = [c[2] for c in due]
            results = pool.map_ordered(tasks, t) if len(tasks) > 1 else [(tasks[0](t), None)]
            for (i, k, *_), (res, exc) in zip(due, results):
                if exc is not None:
                    raise exc
                what, st = res
                if st > 1:
                    if what == "set":
                        fail(i, "setting inputs", st, t)
                    else:
                        step_failed(i, st, t)
            for i, k, _, getters, _ in due:
                for g in getters:
                    if (st := g()) > 1:
                        fail(i, "getting outputs", st, t + h * k)
        for i, k, _, _, publish in comps:
            if publish is not None and (n + 1) % k == 0:
                publish()
    return step


def _task(i, H, transfers, setters, do_step, calls):
    def task(t):
        for x in transfers:
            x()
        for s in setters:
            if (st := s()) > 1:
                return "set", st
        calls[i] += 1
        return "step", do_step(t, H)
    return task
