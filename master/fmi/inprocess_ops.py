"""The fast-path operations of an in-process pythonfmu slave: getters, setters, the step and the inputs-and-step
cycle bound once and called every step, and the descriptions (``InlineCycle``, ``InlineGet``) from which the
compiled step (master/algorithms/compiled.py) writes the same calls into its own code. Each does what the FMU's
binary does through the slave's get_<type>/set_<type>/do_step methods, with the same values and statuses; a call
that raises is retried through the reporting path (``get_port``/``set_port`` of ``PythonFmuSlave``).
"""
from __future__ import annotations

import functools
import operator
import struct
from typing import Callable, NamedTuple

from .slave import DISCARD, OK, SET_FAILED, WARNING

_CONVERT = {"Real": float, "Integer": int, "Boolean": bool, "String": str}


class InlineCycle(NamedTuple):
    """What a cycle op (``bound_cycle``) does, for a compiled step that writes the same calls into its own code
    (no Python frame per component): ``sets`` (update, names, tolist) each called as update(zip(names,
    tolist())); after one raised, ``sets_failed()`` sets the ports again through the reporting path and gives the
    failing port's status (0: they all went through); ``do_step(t, h)`` true is OK, false Discard; after it
    raised, ``step_error(t, h)`` logs and gives the status; ``obj.log_queue`` is drained by ``drain()``;
    ``stores``: when every update of ``sets`` is the ``update`` of this one mapping (a shell that keeps its
    variables as plain attributes hands over its instance's), so that item stores into it are the same updates."""
    sets: tuple
    sets_failed: Callable
    do_step: Callable
    step_error: Callable
    obj: object
    drain: Callable
    stores: dict | None = None


class InlineGet(NamedTuple):
    """What a getter op (``bound_get`` of a slave with ``get_raw``) does, for the compiled step: ``kind``
    "single" is buf[0] = fetch(arg), "pack" pack_into(buf, 0, *fetch(arg)), "assign" buf[:] = fetch(arg); after
    it raised, ``retry()`` reads through the reporting path and gives the status."""
    kind: str
    fetch: Callable
    arg: object
    names: tuple | None         # when ``arg`` is the instance's __dict__: the keys ``fetch`` reads, in order
    buf: object
    pack_into: Callable | None
    retry: Callable
    obj: object
    drain: Callable


def _shell_bind(obj, op, typ, vrs):
    """``obj.cosim_bind(op, typ, vrs)`` (see ``PythonFmuSlave._bound``), or None."""
    bind = getattr(obj, "cosim_bind", None)
    if bind is None:
        return None
    try:
        return bind(op, typ, list(vrs))
    except Exception:       # noqa: BLE001 - an optional shortcut: the FMI functions remain
        return None


class InProcessOps:
    """The fast path of ``PythonFmuSlave`` (a mixin: it uses the slave's ``obj``, ``log``, ``name``, ``_drain``,
    ``get_port``, ``set_port`` and ``_step_error``)."""

    # -- fast-path operations: bound once, called every step ------------------------------------------------
    # The binary calls the slave's get_<type>/set_<type> methods; so do these operations. Where the class keeps
    # pythonfmu's own implementation (which type-checks each variable and calls its getter or setter), the
    # variables are checked once here and their getters/setters called directly, which is the same work.
    def _direct(self, op, typ, vrs):
        from pythonfmu import Fmi2Slave
        from pythonfmu import variables as pv
        name = f"{op}_{typ.lower()}"
        if getattr(type(self.obj), name) is not getattr(Fmi2Slave, name):
            return None
        kind = {"Real": pv.Real, "Integer": pv.Integer, "Boolean": pv.Boolean, "String": pv.String}[typ]
        found = []
        for vr in vrs:
            var = self.obj.vars.get(vr)
            acc = None if var is None else (var.getter if op == "get" else var.setter)
            if not isinstance(var, kind) or acc is None:
                return None
            found.append(acc)
        return found

    def _bound(self, op, typ, vrs):
        """The slave's own fast accessor, if its class offers ``cosim_bind(op, typ, vrs)`` (documented in
        docs/architecture.md: a function equivalent to get_<typ>(vrs) / set_<typ>(vrs, values))."""
        return _shell_bind(self.obj, op, typ, vrs)

    def bound_get(self, typ, port):
        obj, buf, vrs, conv = self.obj, port.buf, port.extra, _CONVERT[typ]
        drain, get_port = self._drain, self.get_port
        # Real and Integer values go into a float64 or integer buffer, which converts them as float() or int()
        # would: the slave may hand them over unconverted (``get_raw``: one C-level attribute fetch, no list, no
        # Python frame); a Boolean buffer holds 0/1 either way, but a String one would keep a non-str
        as_is = typ == "Real" or (typ == "Integer" and buf.dtype.kind in "iu")
        raw = self._bound("get_raw", typ, vrs) if as_is else None
        if raw is not None:
            fetch, single = raw
            retry = functools.partial(get_port, typ, port)
            fetch, src, keys = self._from_dict(fetch)
            if single:
                def op():
                    try:
                        buf[0] = fetch(src)
                    except Exception:
                        return get_port(typ, port)        # again through the reporting path
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("single", fetch, src, keys, buf, None, retry, obj, drain)
            elif buf.flags.c_contiguous and buf.flags.writeable and buf.dtype.isnative:
                # struct writes the values into the buffer's memory in one C loop (numpy's assignment from a
                # tuple converts value by value); a value struct does not take as is raises, and the reporting
                # path below stores it through numpy as before
                pack_into = struct.Struct(f"@{len(buf)}{buf.dtype.char}").pack_into
                mem = memoryview(buf).cast("B")     # the same memory, a cheaper buffer to ask for than numpy's

                def op():
                    try:
                        pack_into(mem, 0, *fetch(src))
                    except Exception:
                        return get_port(typ, port)
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("pack", fetch, src, keys, mem, pack_into, retry, obj, drain)
            else:
                def op():
                    try:
                        buf[:] = fetch(src)
                    except Exception:
                        return get_port(typ, port)
                    if obj.log_queue:
                        drain()
                    return OK
                op.inline = InlineGet("assign", fetch, src, keys, buf, None, retry, obj, drain)
            return op
        read = self._reader(typ, vrs, buf, conv)

        # one frame per call: the read inlined, the log queue looked at only when it holds a message
        def op():
            try:
                read()
            except Exception:
                return get_port(typ, port)        # again through the reporting path
            if obj.log_queue:
                drain()
            return OK
        return op

    def _from_dict(self, fetch):
        """(fetch, what it is called with, the keys it reads or None): an attrgetter of plain instance attributes becomes an itemgetter of the
        same names on the instance's __dict__ (the attribute look-up without its search of the class for a
        descriptor: the same values, as the shell's ``set_raw`` writes them there); else ``fetch`` on the instance."""
        obj = self.obj
        if type(fetch) is not operator.attrgetter or type(obj).__getattribute__ is not object.__getattribute__:
            return fetch, obj, None
        names = fetch.__reduce__()[1]
        d = obj.__dict__
        if not all(type(n) is str and n in d and not hasattr(type(obj), n) for n in names):
            return fetch, obj, None
        return operator.itemgetter(*names), d, tuple(names)

    def _reader(self, typ, vrs, buf, conv):
        """A function filling ``buf`` with the values of ``vrs``: the slave's own fast accessor where it has
        one, else its getters, else its get_<typ>."""
        obj = self.obj
        bound = self._bound("get", typ, vrs)
        if bound is not None:
            if len(vrs) == 1:
                def read():
                    buf[0] = bound()[0]
            else:
                def read():
                    buf[:] = bound()
            return read
        getters = self._direct("get", typ, vrs)
        if getters is not None and len(getters) == 1:
            g = getters[0]

            def read():
                buf[0] = conv(g())
        elif getters is not None:
            def read():
                buf[:] = [conv(g()) for g in getters]
        else:
            method = getattr(obj, f"get_{typ.lower()}")

            def read():
                buf[:] = method(vrs)
        return read

    def bound_set(self, typ, port):
        obj, buf, vrs, conv = self.obj, port.buf, port.extra, _CONVERT[typ]
        bound = self._bound("set", typ, vrs)
        setters = None if bound is not None else self._direct("set", typ, vrs)
        method = getattr(obj, f"set_{typ.lower()}")
        drain, set_port, tolist = self._drain, self.set_port, buf.tolist
        # a float or integer buffer's tolist() holds Python floats or ints already: nothing to convert (a
        # Boolean buffer holds 0/1, which bool() makes True/False)
        as_is = typ == "Real" or (typ == "Integer" and buf.dtype.kind in "iu")
        raw = self._bound("set_raw", typ, vrs) if as_is else None
        if raw is not None:
            update, names = raw          # the slave's own attribute update, called inline: no Python frame

            def op():
                try:
                    update(zip(names, tolist()))
                except Exception:
                    return set_port(typ, port)
                if obj.log_queue:
                    drain()
                return OK
            return op
        if bound is not None and as_is:
            def write():
                bound(tolist())
        elif bound is not None:
            def write():
                bound([conv(v) for v in tolist()])
        elif setters is not None and len(setters) == 1:
            s0 = setters[0]

            def write():
                s0(conv(buf[0]))
        elif setters is not None:
            def write():
                for s, v in zip(setters, tolist()):
                    s(conv(v))
        else:
            def write():
                method(vrs, [conv(v) for v in tolist()])

        def op():
            try:
                write()
            except Exception:
                return set_port(typ, port)
            if obj.log_queue:
                drain()
            return OK
        return op

    def bound_cycle(self, write_ports, calls, index):
        """Inputs and doStep in one call when every input port has the slave's inline update (``set_raw``): the
        same work as the setters and the step bound one by one, without a frame and a status test per port."""
        raws = []
        for typ, port in write_ports:
            raw = self._bound("set_raw", typ, port.extra) if (
                typ == "Real" or (typ == "Integer" and port.buf.dtype.kind in "iu")) else None
            if raw is None:
                return None
            raws.append((raw[0], raw[1], port.buf.tolist))
        obj, do_step, drain, set_port = self.obj, self.obj.do_step, self._drain, self.set_port
        step_error = self._step_error

        def failed():
            """A setter raised: the ports again through the reporting path, in order, up to the failing one
            (its status + SET_FAILED); None when they all go through this time (then the step goes on)."""
            for typ, port in write_ports:
                st = set_port(typ, port)
                if st > WARNING:
                    return SET_FAILED + st
            return None

        def step(t, h):
            calls[index] += 1
            try:
                ok = do_step(t, h)
            except Exception:
                return step_error(t, h)
            if obj.log_queue:
                drain()
            return OK if ok else DISCARD

        def sets_failed():
            st = failed()
            return 0 if st is None else st - SET_FAILED

        if not raws:
            step.inline = InlineCycle((), sets_failed, do_step, step_error, obj, drain)
            return step

        def op(t, h):
            try:
                for u, n, l in raws:
                    u(zip(n, l()))
            except Exception:
                if (st := failed()) is not None:
                    return st
            return step(t, h)
        attrs = getattr(obj, "__dict__", None)
        stores = attrs if attrs is not None and all(u == attrs.update for u, _, _ in raws) else None
        op.inline = InlineCycle(tuple(raws), sets_failed, do_step, step_error, obj, drain, stores)
        return op

    def bound_step(self):
        obj = self.obj
        do_step = obj.do_step

        def op(t, h):
            try:
                ok = do_step(t, h)
            except Exception:
                return self._step_error(t, h)
            if obj.log_queue:
                self._drain()
            return OK if ok else DISCARD
        return op
