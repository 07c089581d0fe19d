"""The reference step of the fixed-step algorithms (jacobi, gauss-seidel): what one master step from t to t+h does,
in plain Python. ``compiled.compile_step`` generates the same step as straight-line code (an accelerator, switched
off by ``COSIM_MASTER_PURE_PYTHON=1``); ``tests/accelerators/`` checks the two against each other.

Per active component in the stepping order, when it is due (a component on step multiple k steps at n = 0, k,
2k, ... with step k*h): its inputs gathered from the output buffer (``Runtime.xfer``: copies with factor and
offset), set into the FMU, its doStep (counted in ``Runtime.do_step_calls``). Gauss-Seidel reads each component's
outputs right after its doStep, so the next component sees them; Jacobi reads all outputs after all doSteps, so
every input of the step comes from the step before. A component on a step multiple writes its outputs into a
staging buffer, published at the end of its macro step. An FMI status above Warning fails the run, except a
doStep that asks to terminate the simulation: the step then goes on, and the run ends after it.
"""
from __future__ import annotations

from ..fmi.slave import WARNING


def reference_step(rt, order: list[int], h: float, gauss_seidel: bool, lengths: dict | None = None):
    """``step(n, t)``: one master step of the active components of ``rt`` in ``order``; ``lengths``: component
    index -> the length of its doStep (its last macro step, ended at the stop time), instead of k h."""
    components = []
    for i in order:
        if rt.active[i]:
            transfers, setters, do_step, getters, publish = rt.fast_ops(i)
            components.append((i, rt.slaves[i], rt.multiple[i], transfers, setters, do_step, getters, publish,
                               (lengths or {}).get(i, h * rt.multiple[i])))
    calls = rt.do_step_calls

    def read_outputs(i, slave, getters, t_end):
        for get in getters:
            if (st := get()) > WARNING:
                raise slave.fail("getting outputs", st, t_end)

    def step(n: int, t: float) -> None:
        for i, slave, k, transfers, setters, do_step, getters, _, hk in components:
            if n % k:
                continue
            rt.calling(i)           # for a supervisor: a crash from here on is this component's
            for transfer in transfers:
                transfer()
            for set_ in setters:
                if (st := set_()) > WARNING:
                    raise slave.fail("setting inputs", st, t)
            calls[i] += 1
            if (st := do_step(t, hk)) > WARNING and not rt.ends_run_on_request(i, st):
                raise slave.fail("doStep", st, t)
            if gauss_seidel:
                read_outputs(i, slave, getters, t + hk)
        for i, slave, k, _, _, _, getters, publish, hk in components:
            if not gauss_seidel and n % k == 0:
                rt.calling(i)
                read_outputs(i, slave, getters, t + hk)
            if publish is not None and (n + 1) % k == 0:
                publish()
        rt.calling(-1)
    return step
