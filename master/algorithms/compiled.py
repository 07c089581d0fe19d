"""Compiling a step of a fixed-step algorithm into straight-line Python: an accelerator (master/accel.py) of the
reference step ``fixed_step.reference_step``, which runs instead when ``COSIM_MASTER_PURE_PYTHON=1``; both give the
same results bit for bit (tests/accelerators/, ``master.compiled-step``).

The generated function calls, per component, prebound callables (FMI getters/setters with their value
reference and buffer pointers fixed, the doStep with its instance fixed): no loops over lists, no tuple
unpacking, no dictionary look-ups and no allocation per step. It is rebuilt only when the set of active
components changes.

An in-process slave whose cycle and getters describe themselves (``op.inline``: fmi/inprocess.py
``InlineCycle``, ``InlineGet``) gets their calls written into the step itself: its inputs' updates, its doStep and
its output fetches run in the step's own frame instead of one Python frame per op (where a shell keeps its variables
as plain instance attributes, as stores into and loads from its ``__dict__``). What happens when one of them raises
is the op's own handling, called from here (retried through the reporting path, logged, reported with the same
status); the step's status is acted on after its ``try``, a setter's or getter's in its ``except`` clause, with the
caught exception kept out of the report (it never showed: the op had handled it before the report was raised).

Jacobi's inputs come from one tuple per buffer type made at the step's start by ``struct`` from just the positions
the step reads (``_unpacker``: the same objects ``tolist`` gives there); the doStep counts of the components that step
every master step are deferred (``_deferred``): the step counts its own complete calls and Execution._steps folds
them into ``rt.do_step_calls`` when it returns, a step cut short by an exception counting the components it reached.

A large system's step is split into chunks of about ``CHUNK_LINES`` lines, each a function the step calls:
compiling one huge function costs far more memory than compiling the same lines as many small ones.
"""
from __future__ import annotations

import re
import struct

from .. import accel
from .fixed_step import reference_step

CHUNK_LINES = 400


def compile_step(rt, order: list[int], h: float, gauss_seidel: bool, lengths: dict | None = None):
    """``step(n, t)``: what ``fixed_step.reference_step`` returns, generated as straight-line code (unless
    accelerators are switched off)."""
    if not accel.enabled():
        return reference_step(rt, order, h, gauss_seidel, lengths)
    from ctypes import c_double
    ns: dict = {"_fail": _failer(rt), "_step_failed": _step_failer(rt), "_D": c_double, "_calls": rt.do_step_calls}
    ns["_cycle_failed"] = _cycle_failer(ns["_fail"], ns["_step_failed"])
    ns["_fail_handling"] = _failer(rt, in_handler=True)
    # a rebuild (a component taken out) reuses the other components' lines and bound ops, and the code of the
    # chunks it leaves as they were (_assemble): a fleet of 256 UAVs rebuilt its whole step once per landing
    memo = getattr(rt, "step_memo", None)
    memo = {} if memo is None else memo.setdefault(("compiled", h, gauss_seidel), {})
    made = memo.setdefault("components", {})
    body: list[tuple] = []     # per component, (key, its lines) (each block one unit of a chunk)
    tail: list[tuple] = []
    for i in order:
        if not rt.active[i]:
            continue
        # a last step cut short to end at the stop time has its own length, so its own lines
        hk = (lengths or {}).get(i, h * rt.multiple[i])
        if (i, hk) not in made:
            made[(i, hk)] = _component(rt, i, hk, gauss_seidel)
        own, lines, after = made[(i, hk)]
        ns.update(own)
        body.append((("step", i), lines))
        tail += [(("after", i, j), b) for j, b in enumerate(after)]
    name = f"<cosim-master step: {'gauss-seidel' if gauss_seidel else 'jacobi'}>"
    fn = _assemble(ns, body + tail, name, rt.out, memo)
    if getattr(fn, "fold", None) is not None:
        rt.call_folds.append(fn.fold)       # Execution._steps folds them in when it returns
    return fn


def _component(rt, i: int, hk: float, gauss_seidel: bool):
    """Component i's part of the step of length hk: (the names its lines use, bound to its ops; its lines in the
    sweep; its blocks after the sweep (Jacobi's output fetches, a staged component's publish))."""
    from ctypes import c_double
    ns: dict = {}
    k = rt.multiple[i]
    ns[f"H{i}"] = hk
    raw = rt.slaves[i].raw_step
    cycle = None if raw is not None else rt.slaves[i].bound_cycle(rt.write_ports[i], rt.do_step_calls, i)
    # a cycle sets the inputs itself: the setters are bound only for the other two ways
    transfers, setters, step, getters, publish = rt.fast_ops(i, setters=cycle is None)
    due = [] if k == 1 else [f"if n % {k} == 0:"]
    inline = getattr(cycle, "inline", None)
    # Jacobi: the inputs of an inline cycle taken from the step's lists of the output values (no copy into
    # the input buffers, no list made per port), when every one is an output's value as it is
    sources = rt.write_sources[i] if inline is not None and not gauss_seidel else [None]
    from_lists = all(p is not None for p in sources)
    lines = []
    for j, x in enumerate(() if from_lists else transfers):
        ns[f"x{i}_{j}"] = x
        lines.append(f"x{i}_{j}()")
    if raw is not None:
        ns[f"d{i}"] = raw
        ns[f"CH{i}"] = c_double(hk)
        for j, s in enumerate(setters):
            ns[f"s{i}_{j}"] = s
            lines.append(f"if (st := s{i}_{j}()) > 1: _fail({i}, 'setting inputs', st, t)")
        lines.append(f"_calls[{i}] += 1")
        lines.append(f"if (st := d{i}(ct, CH{i}, 1)) > 1: _step_failed({i}, st, t)")
    elif inline is not None:
        values = None
        if from_lists:
            values = [_listed(typ, p) for (typ, _), p in zip(rt.write_ports[i], sources)]
        lines += _inline_cycle(ns, i, inline, values)
        if from_lists and transfers:
            ns[f"R{i}"] = _with_transfers(transfers, inline.sets_failed)
    elif cycle is not None:
        # inputs and step in one call (an in-process slave: see Slave.bound_cycle), which counts the step
        ns[f"c{i}"] = cycle
        lines.append(f"if (st := c{i}(t, H{i})) > 1: _cycle_failed({i}, st, t)")
    else:
        ns[f"d{i}"] = step
        for j, s in enumerate(setters):
            ns[f"s{i}_{j}"] = s
            lines.append(f"if (st := s{i}_{j}()) > 1: _fail({i}, 'setting inputs', st, t)")
        lines.append(f"_calls[{i}] += 1")
        lines.append(f"if (st := d{i}(t, H{i})) > 1: _step_failed({i}, st, t)")
    gets = []
    for j, g in enumerate(getters):
        if getattr(g, "inline", None) is not None:
            gets += _inline_get(ns, i, j, g.inline)
            continue
        ns[f"g{i}_{j}"] = g
        gets.append(f"if (st := g{i}_{j}()) > 1: _fail({i}, 'getting outputs', st, t + H{i})")
    if gauss_seidel:
        lines += gets
    after = []
    if not gauss_seidel and gets:
        # Jacobi: nobody reads a value produced in this step, so all outputs are fetched after all steps
        after.append(_under(due, gets))
    if publish is not None:
        ns[f"p{i}"] = publish
        after.append([f"if (n + 1) % {k} == 0: p{i}()"])
    return ns, _under(due, lines), after


def _under(due: list[str], lines: list[str]) -> list[str]:
    """``lines`` under the condition of a component on a step multiple (if any)."""
    return due + ["    " + ln for ln in lines] if due else lines


def _listed(typ: str, positions: list[int]) -> list[str]:
    """The expressions of the values at ``positions`` of the step's list of out[typ] (see ``_assemble``)."""
    return [f"V{typ}[{p}]" for p in positions]


def _with_transfers(transfers, sets_failed):
    """The retry of inputs taken from the lists: their buffers, which the reporting path sets them from, filled
    first (the step skipped the copies)."""
    def retry():
        for x in transfers:
            x()
        return sets_failed()
    return retry


def _inline_cycle(ns: dict, i: int, c, values: list[list[str]] | None = None) -> list[str]:
    """The lines of an in-process slave's inputs and doStep (the cycle op's calls, see ``InlineCycle``);
    ``values``: per input port, the expressions of its values (default: its buffer's ``tolist()``)."""
    ns[f"O{i}"], ns[f"W{i}"], ns[f"D{i}"], ns[f"E{i}"] = c.obj, c.drain, c.do_step, c.step_error
    lines = []
    if c.sets:
        ns[f"R{i}"] = c.sets_failed
        lines.append("try:")
        direct = c.stores is not None
        if direct:
            # update(zip(names, values)) on that mapping is a store of each value under its name, in order: written
            # as such, without the call, the zip and its pairs
            ns[f"S{i}"] = c.stores
        for j, (update, names, tolist) in enumerate(c.sets):
            ns[f"U{i}_{j}"], ns[f"N{i}_{j}"], ns[f"L{i}_{j}"] = update, names, tolist
            if direct and values is not None:
                lines += [f"    S{i}[{n!r}] = {e}" for n, e in zip(names, values[j])]
            elif direct:
                lines.append(f"    {''.join(f'S{i}[{n!r}], ' for n in names)}= L{i}_{j}()")
            elif values is not None:
                lines.append(f"    U{i}_{j}(zip(N{i}_{j}, ({''.join(e + ', ' for e in values[j])})))")
            else:
                lines.append(f"    U{i}_{j}(zip(N{i}_{j}, L{i}_{j}()))")
        lines += ["except Exception:", f"    if st := R{i}(): _fail_handling({i}, 'setting inputs', st, t)"]
    lines += [f"_calls[{i}] += 1",
              "try:", f"    st = 0 if D{i}(t, H{i}) else 2", "except Exception:", f"    st = E{i}(t, H{i})",
              f"if O{i}.log_queue: W{i}()",
              f"if st: _step_failed({i}, st, t)"]
    return lines


_FETCH = {"single": "B{s}[0] = F{s}(A{s})", "pack": "P{s}(B{s}, 0, *F{s}(A{s}))", "assign": "B{s}[:] = F{s}(A{s})"}


def _inline_get(ns: dict, i: int, j: int, g) -> list[str]:
    """The lines of one output port's fetch (``InlineGet``); the status of a retry is acted on as the op's was."""
    s = f"{i}_{j}"
    ns[f"O{i}"], ns[f"W{i}"] = g.obj, g.drain
    ns[f"F{s}"], ns[f"A{s}"], ns[f"B{s}"], ns[f"P{s}"], ns[f"Q{s}"] = g.fetch, g.arg, g.buf, g.pack_into, g.retry
    fetch = _FETCH[g.kind].format(s=s, i=i)
    lines = ["try:", None, "except Exception:",
             f"    if (st := Q{s}()) > 1: _fail_handling({i}, 'getting outputs', st, t + H{i})"]
    if g.names is None:
        lines[1] = "    " + fetch
        return lines + ["else:", f"    if O{i}.log_queue: W{i}()"]
    # the keys read from the instance's __dict__ one by one, as the itemgetter would, without its tuple; no code of
    # the FMU runs, so nothing can have been logged
    keys = "".join(f"A{s}[{k!r}], " for k in g.names)
    lines[1] = "    " + {"single": f"B{s}[0] = A{s}[{g.names[0]!r}]", "pack": f"P{s}(B{s}, 0, {keys})",
                         "assign": f"B{s}[:] = ({keys})"}[g.kind]
    return lines


_LIST_USE = re.compile(r"\bV([A-Z][A-Za-z0-9]*)\b")
_LIST_ITEM = re.compile(r"\bV([A-Z][A-Za-z0-9]*)\[(\d+)\]")
#: struct codes of the buffer types whose values struct gives as ``tolist`` does (a float from the double's bits,
#: an int), by numpy kind and item size
_STRUCT_CODE = {("f", 8): "d", ("i", 1): "b", ("i", 2): "h", ("i", 4): "i", ("i", 8): "q", ("u", 1): "B",
                ("u", 2): "H", ("u", 4): "I", ("u", 8): "Q"}


def _renumbered(blocks: list[list[str]], typ: str, index: dict[int, int]) -> list[list[str]]:
    """``blocks`` with each V{typ}[p] made V{typ}[index[p]]."""
    def item(m):
        return f"V{typ}[{index[int(m.group(2))]}]" if m.group(1) == typ else m.group(0)
    return [[_LIST_ITEM.sub(item, ln) for ln in b] for b in blocks]


def _unpacker(buf, positions: list[int]):
    """(unpack_from, memory) giving the values of ``buf`` at ``positions`` (sorted) as a tuple, the same objects
    ``buf.tolist()`` has there, in one C call that skips the others (``tolist`` made all of a large system's
    outputs into Python objects every step, to use a third of them); None where struct cannot stand in."""
    code = _STRUCT_CODE.get((buf.dtype.kind, buf.dtype.itemsize))
    if code is None or not positions or not (buf.flags.c_contiguous and buf.dtype.isnative and buf.ndim == 1):
        return None
    size, fmt, at = buf.dtype.itemsize, ["@"], 0
    for p in positions:
        if p > at:
            fmt.append(f"{(p - at) * size}x")     # items of one size at multiples of it: '@' adds no padding
        fmt.append(code)
        at = p + 1
    return struct.Struct("".join(fmt)).unpack_from, memoryview(buf).cast("B")


def _assemble(ns: dict, blocks: list[tuple], name: str, out: dict, memo: dict):
    """``def step(n, t)`` running ``blocks`` ((key, lines) each) in order: one function, or chunks of it that the
    step calls. ``memo`` keeps the chunk each block went into and each chunk's code: a block keeps its chunk when
    others are taken out, so a rebuild compiles again only the chunks that lost one."""
    chunk_of = memo.get("chunk_of")
    if chunk_of is None or any(key not in chunk_of for key, _ in blocks):
        chunk_of = memo["chunk_of"] = _layout(blocks)
        memo["parts"] = {}
    if len(set(chunk_of.values())) == 1:
        return _one_function(ns, [ln for _, b in blocks for ln in b], name, out)
    members: dict[int, list] = {}
    for key, b in blocks:
        members.setdefault(chunk_of[key], []).append((key, b))
    parts = memo["parts"]
    head, calls, sources, counted, listed = [], [], [], {}, set()
    for c, chunk in members.items():        # in the order of the blocks: a layout's chunks follow it
        keys = tuple(key for key, _ in chunk)
        if c not in parts or parts[c][0] != keys:
            parts[c] = (keys, *_part(c, [ln for _, b in chunk for ln in b], name, out))
        _, code, src, uses, counted[c] = parts[c]
        args = []
        for typ, positions in uses:
            if positions is None:       # the whole list, made once for every chunk that uses it
                if typ not in listed:
                    listed.add(typ)
                    head.append(f"V{typ} = _out{typ}.tolist()")
                    ns[f"_out{typ}"] = out[typ]
                args.append(f"V{typ}")
                continue
            # only the values this chunk uses, as a tuple in the order of their positions; all taken at the
            # step's start (Jacobi: before the tail of any chunk changes an output)
            head.append(f"V{typ}_{c} = _unpack{typ}_{c}(_mem{typ})")
            ns[f"_unpack{typ}_{c}"], ns[f"_mem{typ}"] = _unpacker(out[typ], positions)
            args.append(f"V{typ}_{c}")
        calls.append(f"_part{c}(n, t{''.join(', ' + a for a in args)})")
        sources.append(src)
        exec(code, ns)
    _fold_counts(ns, counted)
    sources.append(_function("step", head + calls + ["_ran[0] += 1"]))
    exec(_code(sources[-1], name), ns)
    fn = ns["step"]
    fn.source = "".join(sources)
    fn.fold = ns["_fold"]
    return fn


def _layout(blocks: list[tuple]) -> dict:
    """Block key -> chunk: consecutive blocks, a new chunk where one would pass ``CHUNK_LINES`` lines."""
    chunk_of, c, size = {}, 0, 0
    for key, b in blocks:
        if size and size + len(b) > CHUNK_LINES:
            c, size = c + 1, 0
        chunk_of[key] = c
        size += len(b)
    return chunk_of


def _part(c: int, lines: list[str], name: str, out: dict):
    """Chunk c as ``_part{c}(n, t, V...)``: (its code, its source, per list it reads (type, the positions it
    reads, or None for the whole list), the components whose doStep counts it defers)."""
    uses = []
    for typ in sorted({m.group(1) for ln in lines for m in _LIST_USE.finditer(ln)}):
        used = sorted({int(m.group(2)) for ln in lines for m in _LIST_ITEM.finditer(ln) if m.group(1) == typ})
        if _unpacker(out[typ], used) is None:
            uses.append((typ, None))
            continue
        uses.append((typ, used))
        lines = _renumbered([lines], typ, {p: k for k, p in enumerate(used)})[0]
    comps = _deferred(lines)
    params = "".join(f", V{typ}" for typ, _ in uses)
    src = _function(f"_part{c}", _counting(c, lines, True), params)
    return _code(src, name), src, uses, comps


def _one_function(ns: dict, lines: list[str], name: str, out: dict):
    """``def step(n, t)`` of ``lines`` in one function."""
    uses, comps, src = _one_function_text(lines, out)
    for typ, used in uses:
        if used is None:
            ns[f"_out{typ}"] = out[typ]
        else:
            ns[f"_unpack{typ}"], ns[f"_mem{typ}"] = _unpacker(out[typ], used)
    if comps:
        _fold_counts(ns, {0: comps})
    exec(_code(src, name), ns)
    fn = ns["step"]
    fn.source = src
    if comps:
        fn.fold = ns["_fold"]
    return fn


#: ``_one_function``'s text by its lines and the kinds of the output buffers: the runs of one structure give the
#: same lines (what differs between them is bound in the run's namespace), and reading the lists they use out of
#: them again was most of a small system's step build. Bounded: emptied when full.
_TEXT_CACHE: dict = {}


def _one_function_text(lines: list[str], out: dict) -> tuple[list, list[int], str]:
    """(per list the step reads: its type and the positions read, or None for the whole list; the components whose
    doStep counts it defers; its source)."""
    key = (tuple(lines), tuple((typ, _buffer_kind(buf)) for typ, buf in out.items()))
    text = _TEXT_CACHE.get(key)
    if text is None:
        if len(_TEXT_CACHE) >= CODE_CACHE_SIZE:
            _TEXT_CACHE.clear()
        text = _TEXT_CACHE[key] = _make_one_function_text(lines, out)
    return text


def _buffer_kind(buf) -> tuple:
    """What of an output buffer ``_unpacker`` decides by, apart from the positions."""
    return buf.dtype.kind, buf.dtype.itemsize, buf.dtype.isnative, buf.flags.c_contiguous, buf.ndim


def _make_one_function_text(lines: list[str], out: dict) -> tuple[list, list[int], str]:
    # the lists of the output values the step's inputs are taken from, made once at its start (Jacobi: no output
    # changes before the tail, which comes after every input is set)
    head, uses = [], []
    for typ in sorted({m.group(1) for ln in lines for m in _LIST_USE.finditer(ln)}):
        used = sorted({int(m.group(2)) for ln in lines for m in _LIST_ITEM.finditer(ln) if m.group(1) == typ})
        if _unpacker(out[typ], used) is None:
            head.append(f"V{typ} = _out{typ}.tolist()")
            uses.append((typ, None))
            continue
        # only the values the step uses, as a tuple in the order of their positions
        head.append(f"V{typ} = _unpack{typ}(_mem{typ})")
        uses.append((typ, used))
        lines = _renumbered([lines], typ, {p: k for k, p in enumerate(used)})[0]
    lines = list(lines)
    comps = _deferred(lines)
    if comps:
        src = _function("step", _counting(0, head + lines, True) + ["_ran[0] += 1"])
    else:
        src = _function("step", head + lines)
    return uses, comps, src


_COUNT = re.compile(r"_calls\[(\d+)\] \+= 1")


def _deferred(lines: list[str]) -> list[int]:
    """The doStep counts of the components that step every master step (their unindented ``_calls[i] += 1``)
    taken out of ``lines`` (changed in place): the step counts its own complete calls instead (``_ran``), one
    increment instead of one per component, and ``fold()`` adds them to ``rt.do_step_calls``; each such line
    becomes ``_k = m``, the number of them reached in its chunk, which a step cut short by an exception counts
    (``_partial``) before it goes on. Returns the components whose counts are deferred, in order."""
    comps = []
    for j, ln in enumerate(lines):
        m = _COUNT.fullmatch(ln)
        if m:
            comps.append(int(m.group(1)))
            lines[j] = f"_k = {len(comps)}"
    return comps


def _fold_counts(ns: dict, counted: dict[int, list[int]]) -> None:
    """``_ran``, ``_partial(chunk, reached)`` and ``_fold()`` of the step's deferred counts, ``counted``: chunk ->
    its components whose counts are deferred (in the order of the chunks)."""
    calls = ns["_calls"]
    ran = ns["_ran"] = [0]
    every = [i for comps in counted.values() for i in comps]

    def partial(chunk: int, reached: int) -> None:
        for c, comps in counted.items():
            if c == chunk:
                for i in comps[:reached]:
                    calls[i] += 1
                return
            for i in comps:
                calls[i] += 1

    def fold() -> None:
        r, ran[0] = ran[0], 0
        if r:
            for i in every:
                calls[i] += r
    ns["_partial"] = partial
    ns["_fold"] = fold


def _counting(chunk: int, lines: list[str], counted: bool) -> list[str]:
    """``lines`` in the ``try`` that counts the components a step cut short by an exception has reached (when
    ``counted``: the step defers counts)."""
    if not counted:
        return lines
    return (["_k = 0", "try:"] + ["    " + ln for ln in lines]
            + ["except BaseException:", f"    _partial({chunk}, _k)", "    raise"])


#: compiled step sources, by (source, name): the runs of one structure generate the same text (every value it
#: uses is a name bound in the run's own namespace), and compiling it was most of a step's build. A code object is
#: immutable, so sharing it between runs changes nothing they do. Bounded: emptied when full.
_CODE_CACHE: dict = {}
CODE_CACHE_SIZE = 64


def _code(src: str, name: str):
    key = (src, name)
    code = _CODE_CACHE.get(key)
    if code is None:
        if len(_CODE_CACHE) >= CODE_CACHE_SIZE:
            _CODE_CACHE.clear()
        code = _CODE_CACHE[key] = compile(src, name, "exec")
    return code


def _function(fname: str, lines: list[str], params: str = "") -> str:
    head = ["ct = _D(t)"] if any("(ct, " in ln for ln in lines) else []     # one c_double of t for the raw steps
    return f"def {fname}(n, t{params}):\n" + "".join(f"    {ln}\n" for ln in head + lines or ["pass"])


def _failer(rt, in_handler: bool = False):
    """``fail(i, what, status, t)`` raising slave i's error; ``in_handler``: for a call from an ``except`` clause of
    the step, whose exception the error does not show as its context (the op's report never did: it came after
    the op had handled the exception and returned)."""
    if in_handler:
        def fail_handling(i, what, status, t):
            raise rt.slaves[i].fail(what, status, t) from None
        return fail_handling

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
