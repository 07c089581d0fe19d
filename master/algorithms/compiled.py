"""Compiling a step of a fixed-step algorithm into straight-line Python.

The generated function calls, per component, prebound callables (FMI getters/setters with their value
reference and buffer pointers fixed, the doStep with its instance fixed): no loops over lists, no tuple
unpacking, no dictionary look-ups and no allocation per step. It is rebuilt only when the set of active
components changes.
"""
from __future__ import annotations


def compile_step(rt, order: list[int], h: float, gauss_seidel: bool):
    from ctypes import c_double
    ns: dict = {"_fail": _failer(rt), "_step_failed": _step_failer(rt), "_D": c_double, "_calls": rt.do_step_calls}
    ns["_cycle_failed"] = _cycle_failer(ns["_fail"], ns["_step_failed"])
    uses_ct = False
    body: list[str] = []
    tail: list[str] = []
    active = [i for i in order if rt.active[i]]
    for i in active:
        k = rt.multiple[i]
        transfers, setters, step, getters, publish = rt.fast_ops(i)
        ns[f"H{i}"] = h * k
        raw = rt.slaves[i].raw_step
        cycle = None if raw is not None else rt.slaves[i].bound_cycle(rt.write_ports[i], rt.do_step_calls, i)
        if raw is not None:
            ns[f"d{i}"] = raw
            ns[f"CH{i}"] = c_double(h * k)
            call = f"d{i}(ct, CH{i}, 1)"
            uses_ct = True
        else:
            ns[f"d{i}"] = step
            call = f"d{i}(t, H{i})"
        due = [] if k == 1 else [f"if n % {k} == 0:"]
        ind = "    " * (2 if due else 1)
        lines = []
        for j, x in enumerate(transfers):
            ns[f"x{i}_{j}"] = x
            lines.append(f"{ind}x{i}_{j}()")
        if cycle is not None:
            # inputs and step in one call (an in-process slave: see Slave.bound_cycle), which counts the step
            ns[f"c{i}"] = cycle
            lines.append(f"{ind}if (st := c{i}(t, H{i})) > 1: _cycle_failed({i}, st, t)")
        else:
            for j, s in enumerate(setters):
                ns[f"s{i}_{j}"] = s
                lines.append(f"{ind}if (st := s{i}_{j}()) > 1: _fail({i}, 'setting inputs', st, t)")
            lines.append(f"{ind}_calls[{i}] += 1")
            lines.append(f"{ind}if (st := {call}) > 1: _step_failed({i}, st, t)")
        gets = []
        for j, g in enumerate(getters):
            ns[f"g{i}_{j}"] = g
            gets.append(f"{ind}if (st := g{i}_{j}()) > 1: _fail({i}, 'getting outputs', st, t + H{i})")
        if gauss_seidel:
            lines += gets
        body += ["    " + d for d in due] + lines
        if not gauss_seidel and gets:
            # Jacobi: nobody reads a value produced in this step, so all outputs are fetched after all steps
            tail += ["    " + d for d in due] + gets
        if publish is not None:
            ns[f"p{i}"] = publish
            tail.append(f"    if (n + 1) % {k} == 0: p{i}()")
    head = ["    ct = _D(t)"] if uses_ct else []
    src = "def step(n, t):\n" + "\n".join(head + body + tail or ["    pass"]) + "\n"
    exec(compile(src, f"<cosim-master step: {'gauss-seidel' if gauss_seidel else 'jacobi'}>", "exec"), ns)
    fn = ns["step"]
    fn.source = src
    return fn


def _failer(rt):
    def fail(i, what, status, t):
        raise rt.slaves[i].fail(what, status, t)
    return fail


def _step_failer(rt):
    def step_failed(i, status, t):
        """A doStep above Warning: an FMU that asked to terminate the simulation ends the run after this
        step (the rest of the step goes on, so that every output is read at its end); anything else fails."""
        if not rt.ends_run_on_request(i, status):
            raise rt.slaves[i].fail("doStep", status, t)
    return step_failed


def _cycle_failer(fail, step_failed):
    from ..fmi.slave import SET_FAILED

    def cycle_failed(i, status, t):
        """A combined inputs-and-step call above Warning: its inputs failed (status + SET_FAILED) or its step."""
        if status >= SET_FAILED:
            fail(i, "setting inputs", status - SET_FAILED, t)
        step_failed(i, status, t)
    return cycle_failed
