"""The running system: slave instances, the value buffers that connect them, and the life cycle.

Layout of the buffers (one set per base type): every value the master reads from a slave (connected
outputs, recorded and monitored variables) lives in ``out[T]``, contiguous per slave (the ones read after
every step first, then the ones read only when the results are sampled); every value it
writes to a slave lives in ``inb[T]``, contiguous per slave, with ``src[T]`` giving for each input slot
the index in ``out[T]`` it comes from. A transfer is therefore one ``np.take`` (plus a multiply-add where
a unit conversion or linear transformation applies) and one FMI setter call per slave and type.
"""
from __future__ import annotations

import functools

import numpy as np

from .errors import CosimError
from .fmi.logsink import LogSink
from .fmi.factory import make_slave
from .fmi.locale_guard import keep_character_type
from .fmi.slave import BASE_TYPES, ERROR, FATAL, WARNING, new_buffer
from .plan import Link, Plan, Var, shown_source


PHASE_INSTANTIATE, PHASE_INITIALIZE, PHASE_STEP, PHASE_TERMINATE = 1, 2, 3, 4
PHASE_NAMES = {1: "instantiation", 2: "initialization", 3: "a step", 4: "termination"}


class SavedPoint:
    """Every active FMU's state and the master's value buffers at time t (rollback: ``Execution.save_state``,
    the iterative algorithm). ``restore`` may be called any number of times; ``release`` frees the FMU states."""

    def __init__(self, rt: "Runtime", t: float):
        self.rt, self.t = rt, t
        self.tokens = [s.save_state(t) if on else None for s, on in zip(rt.slaves, rt.active)]
        self.buffers = {name: {typ: a.copy() for typ, a in getattr(rt, name).items()} for name in ("out", "inb")}
        self.staged = [[buf.copy() for buf, _ in st] if st else None for st in rt.staging]

    def restore(self) -> None:
        rt = self.rt
        for slave, token in zip(rt.slaves, self.tokens):
            if token is not None:
                slave.restore_state(token, self.t)
        for name, by_type in self.buffers.items():
            for typ, a in by_type.items():
                getattr(rt, name)[typ][:] = a
        for st, copies in zip(rt.staging, self.staged):
            for (buf, _), copy in zip(st or (), copies or ()):
                buf[:] = copy

    def release(self) -> None:
        for slave, token in zip(self.rt.slaves, self.tokens):
            if token is not None:
                slave.release_state(token)
        self.tokens = [None] * len(self.tokens)


class Runtime:
    def __init__(self, plan: Plan, observed: list[Var], log: LogSink, step_multiples: dict[str, int] | None = None,
                 logging_on: bool = False, inprocess: bool = False, sampled: list[Var] | None = None,
                 solver=None):
        """``observed``: variables read after every step (monitors); ``sampled``: variables needed only when
        the results are sampled (recording), read by :meth:`read_samples` then, not after every step;
        ``solver``: the integrator of model-exchange components (fmi.ode_solvers.SolverChoice)."""
        self.plan = plan
        self.log = log
        self.names = list(plan.fmus)
        self.index = {n: i for i, n in enumerate(self.names)}
        n = len(self.names)
        self.multiple = [int((step_multiples or {}).get(name, 1)) for name in self.names]
        self.active = [True] * n
        self.changed = False          # set when a component is taken out; algorithms rebuild their step
        self.stop_reason = None       # set by a monitor that ends the run early
        self.probe = None             # a supervisor's shared array: [phase code, component index] (supervise.py)
        self.slaves = [None] * n
        self.do_step_calls = [0] * n  # per component, rolled-back steps included: the work a run cost (run.json)
        self.call_folds = []          # compiled steps' deferred doStep counts (compiled.py): fold() adds them in
        # what the compiled step keeps between its rebuilds (compiled.py: per component its lines and bound ops,
        # per chunk its code), so that taking a component out recompiles only the chunk it was in
        self.step_memo = {}
        self._logging_on = logging_on
        self._inprocess = inprocess
        self._solver = solver

        # what is read from each slave: connection sources first, then monitored variables (both after every
        # step), then the variables only recorded (read when a sample is taken; a component on a multiple of
        # the step reads them with its step, because its outputs are staged)
        self._input_links = self._complete_arrays(plan.links)
        self._held_pos: dict[int, int] = {}
        reads: list[dict[str, list[Var]]] = [{t: [] for t in BASE_TYPES} for _ in range(n)]
        seen = set()

        def want(v: Var):
            if v.qualified in seen:
                return
            for e in plan.elements(v) if v.index is not None else (v,):   # an array is read whole, in order
                seen.add(e.qualified)
                reads[self.index[e.component]][e.type].append(e)
        for ln in plan.links:
            want(ln.src)
        for v in observed:
            want(v)
        self._n_step_reads = [{t: len(reads[i][t]) for t in BASE_TYPES} for i in range(n)]
        for v in sampled or ():
            want(v)
        for i in range(n):
            if self.multiple[i] > 1:
                self._n_step_reads[i] = {t: len(reads[i][t]) for t in BASE_TYPES}
        self.out: dict[str, np.ndarray] = {}
        self.out_pos: dict[str, int] = {}             # qualified name -> index in out[its type]
        self.out_slice: dict[str, list[tuple[int, int]]] = {}
        for t in BASE_TYPES:
            pos = 0
            slices = []
            for i in range(n):
                for v in reads[i][t]:
                    self.out_pos[v.qualified] = pos
                    pos += 1
                slices.append((pos - len(reads[i][t]), pos))
            held = self._held_slots(t, pos)
            pos += len(held)
            self.out[t] = new_buffer(t, pos)
            for p, value in held:
                self.out[t][p] = value
            self.out_slice[t] = slices
        self.real_zeros = np.zeros(len(self.out["Real"]))
        self._reads = reads

        # what is written to each slave; links into parameters are applied during initialization only
        writes: list[dict[str, list]] = [{t: [] for t in BASE_TYPES} for _ in range(n)]
        init_writes: list[dict[str, list]] = [{t: [] for t in BASE_TYPES} for _ in range(n)]
        for ln in self._input_links:
            target = writes if ln.dst.causality == "input" else init_writes
            target[self.index[ln.dst.component]][ln.dst.type].append(ln)
        self._writes, self._init_writes = writes, init_writes
        self.inb: dict[str, np.ndarray] = {}
        self.src: dict[str, np.ndarray] = {}
        self.factor: dict[str, np.ndarray] = {}
        self.offset: dict[str, np.ndarray] = {}
        self.in_slice: dict[str, list[tuple[int, int]]] = {}
        for t in BASE_TYPES:
            links = [ln for i in range(n) for ln in writes[i][t]] + [ln for i in range(n) for ln in init_writes[i][t]]
            self.inb[t] = new_buffer(t, len(links))
            self.src[t] = np.array([self._held_pos.get(id(ln)) if ln.src is None else self.out_pos[ln.src.qualified]
                                    for ln in links], dtype=np.intp)
            self.factor[t] = np.array([ln.factor for ln in links], dtype=np.float64)
            self.offset[t] = np.array([ln.offset for ln in links], dtype=np.float64)
            slices, pos = [], 0
            for group in (writes, init_writes):
                for i in range(n):
                    slices.append((pos, pos + len(group[i][t])))
                    pos += len(group[i][t])
            self.in_slice[t] = slices   # first n: step inputs, next n: init-only inputs

    def _complete_arrays(self, links: list[Link]) -> list[Link]:
        """The links in the order inputs are set, with every array input whole: its elements side by side in
        FMI 3 order (one value reference, all values), an element nobody connects held at its start value (a
        link without source; ``_held_slots``)."""
        first: dict[tuple, int] = {}
        by_dst = {ln.dst.qualified: ln for ln in links}
        ordered = []
        for k, ln in enumerate(links):
            d = ln.dst
            key = (d.component, d.array) if d.index is not None else (k,)
            if key in first:
                continue
            first[key] = k
            if d.index is None:
                ordered.append(ln)
                continue
            ordered += [by_dst.get(e.qualified) or Link(None, e) for e in self.plan.elements(d)]
        return ordered

    def _held_slots(self, t: str, pos: int) -> list[tuple[int, object]]:
        """Slots after the read values of type ``t`` for the unconnected elements of connected array inputs,
        holding the value given to the element (a parameter) or its start value; returns (slot, value)."""
        given = None            # built when a held element needs it: most systems have none
        held = []
        for ln in self._input_links:
            if ln.src is None and ln.dst.type == t:
                if given is None:
                    given = {v.qualified: value for v, value, _ in self.plan.params}
                whole = self.plan.variables[ln.dst.component][ln.dst.array]
                value = given[whole.qualified][ln.dst.index] if whole.qualified in given else ln.dst.start
                self._held_pos[id(ln)] = pos + len(held)
                held.append((pos + len(held), value))
        return held

    def step_reads(self, i: int, typ: str) -> int:
        """How many of slave i's values of type ``typ`` are read after every step (the first ones of its slice
        of ``out[typ]``; the rest are read when a sample is taken)."""
        return self._n_step_reads[i][typ]

    def nonfinite_error(self, t: float) -> CosimError | None:
        """An error naming the Real values read so far that are NaN or infinite, or None when all are finite.
        One dot product with zeros finds them (0 * finite = 0; 0 * NaN or 0 * inf = NaN): cheap per step."""
        out = self.out["Real"]
        if not len(out) or out.dot(self.real_zeros) == 0.0:
            return None
        bad = np.flatnonzero(~np.isfinite(out))
        if not len(bad):
            return None
        names = {pos: q for q, pos in self.out_pos.items() if self.plan.var(q).type == "Real"}
        shown = [f"{names[p]} = {out[p]}" for p in bad[:5]]
        comps = sorted({self.plan.var(names[p]).component for p in bad})
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        return CosimError(f"non-finite output {', '.join(shown)}{more} (a run stops at the first NaN or infinite value; "
                          "--allow-nonfinite lets them through)", file=self.plan.shown_as,
                          element=f"component{'s' if len(comps) > 1 else ''} {', '.join(comps)}", time=t)

    def _at(self, phase: int, i: int) -> None:
        if self.probe is not None:
            self.probe[0], self.probe[1] = phase, i

    def calling(self, i: int) -> None:
        """Slave i's calls of a step come next (-1: none), for a supervisor that names the component a crash or a
        hang is in (supervise.py); a step whose code the supervisor maps line by line need not say it."""
        if self.probe is not None:
            self.probe[1] = i

    # -- life cycle -----------------------------------------------------------------------
    def instantiate(self, start: float, stop: float | None, tolerance: float | None = None):
        """``tolerance``: for every FMU; None gives each FMU its own default experiment tolerance."""
        with keep_character_type():
            self._instantiate(start, stop, tolerance)
        self._bind_ports()
        self.bind_samples()

    def _instantiate(self, start: float, stop: float | None, tolerance: float | None):
        for i, name in enumerate(self.names):
            self._at(PHASE_INSTANTIATE, i)
            fmu = self.plan.fmus[name]
            shown = shown_source(self.plan.shown_as, self.plan.model.components[name].source)
            slave = make_slave(name, fmu, self.log, shown, logging_on=self._logging_on, inprocess=self._inprocess,
                               solver=self._solver)
            self.slaves[i] = slave
            slave.instantiate()
            tol = tolerance
            if tol is None and fmu.md.defaultExperiment is not None and fmu.md.defaultExperiment.tolerance:
                tol = float(fmu.md.defaultExperiment.tolerance)
            slave.setup(start, stop, tol)

    def _bind_ports(self):
        n = len(self.names)
        self.read_ports = [[] for _ in range(n)]
        self.sample_ports = [[] for _ in range(n)]
        self.staging = [None] * n
        self.write_ports = [[] for _ in range(n)]
        self.init_ports = [[] for _ in range(n)]
        self.xfer = [[] for _ in range(n)]
        self.init_xfer = [[] for _ in range(n)]
        # per step input port: the positions in out[its type] whose values it is set to, when it takes them as
        # they are (a plain copy or the output buffer itself; None after a conversion or mapping)
        self.write_sources = [[] for _ in range(n)]
        self._getters = [None] * n       # bound once where the slave allows it in initialization (``_step_getters``)
        for i, slave in enumerate(self.slaves):
            staged = []
            for t in BASE_TYPES:
                a, b = self.out_slice[t][i]
                c = a + self._n_step_reads[i][t]
                if b > c:
                    vrs = [v.vr for v in self._reads[i][t][c - a:]]
                    self.sample_ports[i].append((t, slave.make_port(t, vrs, self.out[t][c:b])))
                b = c
                if b > a:
                    vrs = [v.vr for v in self._reads[i][t][:b - a]]
                    view = self.out[t][a:b]
                    if self.multiple[i] > 1:
                        # a slower component's new outputs become visible when its macro step ends
                        buf = view.copy()
                        staged.append((buf, view))
                        self.read_ports[i].append((t, slave.make_port(t, vrs, buf)))
                    else:
                        self.read_ports[i].append((t, slave.make_port(t, vrs, view)))
                for kind, ports, xfer, offset in (("step", self.write_ports, self.xfer, 0),
                                                  ("init", self.init_ports, self.init_xfer, n)):
                    a, b = self.in_slice[t][offset + i]
                    if b <= a:
                        continue
                    links = (self._writes if kind == "step" else self._init_writes)[i][t]
                    vrs = [ln.dst.vr for ln in links]
                    src = self.src[t][a:b]
                    f, o = self.factor[t][a:b], self.offset[t][a:b]
                    # these few values tested as Python numbers: numpy's calls cost more than the tests
                    positions = src.tolist()
                    affine = t == "Real" and (any(x != 1.0 for x in f.tolist()) or any(x != 0.0 for x in o.tolist()))
                    maps = [(k, ln.mapping) for k, ln in enumerate(links) if ln.mapping]
                    if kind == "step":
                        self.write_sources[i].append(None if affine or maps else positions)
                    if not affine and not maps and all(q - p == 1 for p, q in zip(positions, positions[1:])):
                        # the inputs are a contiguous run of outputs: the setter reads the output buffer itself
                        view = self.out[t][src[0]:src[0] + len(src)]
                        ports[i].append((t, slave.make_port(t, vrs, view)))
                        continue
                    view = self.inb[t][a:b]
                    ports[i].append((t, slave.make_port(t, vrs, view)))
                    xfer[i].append((t, self.out[t], src, view, f if affine else None, o, maps))
            self.staging[i] = staged or None

    def fast_ops(self, i: int, setters: bool = True):
        """Callables for the compiled step of slave i: (transfers, setters, step, getters, publish or None);
        ``setters`` false: None for the setters (a step that sets the inputs another way need not bind them)."""
        slave = self.slaves[i]
        transfers = [self._transfer_op(entry) for entry in self.xfer[i]]
        setters = [slave.bound_set(t, port) for t, port in self.write_ports[i]] if setters else None
        getters = self._step_getters(i) or [slave.bound_get(t, port) for t, port in self.read_ports[i]]
        publish = functools.partial(self.publish, i) if self.staging[i] else None
        return transfers, setters, slave.bound_step(), getters, publish

    def _step_getters(self, i: int) -> list | None:
        """Slave i's bound getters of the values read after every step, bound once and shared by the initialization
        and the compiled step, when the slave's bound getters do what ``get_port`` does in initialization mode too
        (``Slave.bound_get_in_init``); else None."""
        if not self.slaves[i].bound_get_in_init:
            return None
        ops = self._getters[i]
        if ops is None:
            slave = self.slaves[i]
            ops = self._getters[i] = [slave.bound_get(t, port) for t, port in self.read_ports[i]]
        return ops

    def _read_outputs(self, i: int, t: float):
        """``get_outputs`` through the bound getters where the slave has them in initialization."""
        ops = self._step_getters(i)
        if ops is None:
            return self.get_outputs(i, t)
        slave = self.slaves[i]
        for op, (typ, _) in zip(ops, self.read_ports[i]):
            st = op()
            if st > WARNING:
                raise slave.fail(f"getting outputs ({typ})", st, t)
        for op, _, typ in self._sample_ops[i]:
            st = op()
            if st > WARNING:
                raise slave.fail(f"getting outputs ({typ})", st, t)

    def bind_samples(self):
        """Bind the reads of the recorded-only variables (after instantiation; see :meth:`read_samples`)."""
        self._sample_ops = [[(slave.bound_get(t, port), slave, t) for t, port in self.sample_ports[i]]
                            for i, slave in enumerate(self.slaves)]

    def read_samples(self, t: float):
        """Read the variables that are only recorded, from every active component (a component taken out
        keeps the values it had)."""
        active = self.active
        for i, ops in enumerate(self._sample_ops):
            if ops and active[i]:
                for op, slave, typ in ops:
                    st = op()
                    if st > WARNING:
                        raise slave.fail(f"getting recorded outputs ({typ})", st, t)

    def deactivate(self, i: int):
        if self.active[i]:
            for op, slave, typ in self._sample_ops[i]:    # its recorded values freeze at its last step
                st = op()
                if st > WARNING:
                    raise slave.fail(f"getting recorded outputs ({typ})", st)
            self.active[i] = False
            self.changed = True

    def apply_start_values(self, start: float):
        """The plan's parameters and start values, in its order. A slave that takes every one of its values in one
        call per type (``Slave.values_setter``) gets them so; the others one value per call, in the plan's order
        (a slave that declines one type gets all of its values that way: a setter with code of its own then sees
        the others as one by one would)."""
        params = self.plan.params
        index = self.index
        by_slave: dict[int, dict[str, list[int]]] = {}      # slave -> type -> positions in params, in order
        for k, (v, _, _) in enumerate(params):
            by_slave.setdefault(index[v.component], {}).setdefault(v.type, []).append(k)
        one_by_one = set()
        for i, by_type in by_slave.items():
            slave = self.slaves[i]
            puts = [(slave.values_setter(typ, [params[k][0].vr for k in ks]), ks) for typ, ks in by_type.items()]
            if not (all(put is not None for put, _ in puts)
                    and all(put([params[k][1] for k in ks]) for put, ks in puts)):
                one_by_one.update(k for ks in by_type.values() for k in ks)
        for k, (v, value, origin) in enumerate(params):
            if k not in one_by_one:
                continue
            slave = self.slaves[index[v.component]]
            st = slave.set_value(v.type, v.vr, value)
            if st > WARNING:
                raise slave.fail(f"setting {v.name}={value!r} ({origin})", st, start)

    # -- value transfer ---------------------------------------------------------------------
    def _transfer_op(self, entry):
        """One transfer as a callable of no argument. A plain copy (no conversion, no mapping) is the buffer's own
        ``take`` bound to its arguments: no Python frame per call. mode 'clip' spares the copy of ``view`` that
        'raise' makes; the indices are positions in ``out`` by construction, so it takes the same values."""
        t, out, src, view, f, o, maps = entry
        if f is None and not maps:
            return functools.partial(out.take, src, None, view, "clip")
        return functools.partial(self._transfer, [entry])

    @staticmethod
    def _transfer(entries):
        for t, out, src, view, f, o, maps in entries:
            np.take(out, src, out=view)
            if f is not None:
                view *= f
                view += o
            for k, mapping in maps:
                view[k] = mapping.get(out[src[k]], out[src[k]])

    def set_inputs(self, i: int, t: float):
        slave = self.slaves[i]
        for typ, port in self.write_ports[i]:
            st = slave.set_port(typ, port)
            if st > WARNING:
                raise slave.fail(f"setting inputs ({typ})", st, t)

    def get_outputs(self, i: int, t: float):
        """Every output the master reads from slave i (the step's and the recorded-only ones)."""
        slave = self.slaves[i]
        for typ, port in self.read_ports[i] + self.sample_ports[i]:
            st = slave.get_port(typ, port)
            if st > WARNING:
                raise slave.fail(f"getting outputs ({typ})", st, t)

    def complete_call_counts(self) -> None:
        """``do_step_calls`` complete again: the doStep counts an accelerated step defers (compiled.py) added in."""
        for fold in self.call_folds:
            fold()

    def publish(self, i: int):
        for buf, view in self.staging[i]:
            view[:] = buf

    # -- initialization ---------------------------------------------------------------------
    def initialize(self, start: float, order: list[int], has_algebraic_loop: bool, loop_desc: str,
                   tolerance: float = 1e-12, max_iterations: int = 100):
        """Enter initialization mode and propagate outputs to inputs until the connected values settle."""
        with keep_character_type():
            self._initialize(start, order, has_algebraic_loop, loop_desc, tolerance, max_iterations)

    def _initialize(self, start, order, has_algebraic_loop, loop_desc, tolerance, max_iterations):
        for i, slave in enumerate(self.slaves):
            self._at(PHASE_INITIALIZE, i)
            slave.enter_init(start)
        for i in order:
            self._read_outputs(i, start)
            if self.staging[i]:
                self.publish(i)
        limit = max_iterations if has_algebraic_loop else len(order) + 2
        settled = False
        for _ in range(limit):
            before = {t: self.out[t].copy() for t in BASE_TYPES}
            for i in order:
                self._transfer(self.xfer[i])
                self._transfer(self.init_xfer[i])
                self.set_inputs(i, start)
                slave = self.slaves[i]
                for typ, port in self.init_ports[i]:
                    st = slave.set_port(typ, port)
                    if st > WARNING:
                        raise slave.fail(f"setting connected parameters ({typ})", st, start)
                self._read_outputs(i, start)
                if self.staging[i]:
                    self.publish(i)
            if all(_same(before[t], self.out[t], tolerance) for t in BASE_TYPES):
                settled = True
                break
        if not settled:
            raise CosimError(f"initialization did not settle after {limit} iterations: algebraic loop {loop_desc}",
                             file=self.plan.shown_as, element="initialization", time=start)
        for i, slave in enumerate(self.slaves):
            self._at(PHASE_INITIALIZE, i)
            slave.exit_init(start)
        for i in order:
            self._read_outputs(i, start)
            if self.staging[i]:
                self.publish(i)

    def ends_run_on_request(self, i: int, status: int) -> bool:
        """After slave i's doStep returned ``status`` above Warning: True when the FMU asked to terminate the
        simulation (FMI's terminateSimulation). The run then ends normally after this step, with the reason
        in run.json, as when a monitor stops it."""
        slave = self.slaves[i]
        if not slave.asks_to_terminate(status):
            return False
        if self.stop_reason is None:
            self.stop_reason = f"component {slave.name} asked to terminate the simulation"
        return True

    def terminate(self):
        """Terminate and free every instance; errors here are logged, not raised, to keep the results. FMI
        forbids fmi*Terminate after a call returned Error (only freeInstance is allowed then) and any call
        after Fatal, so such instances are left alone."""
        for i, slave in enumerate(self.slaves):
            if slave is None or slave.error_status >= ERROR:
                continue
            self._at(PHASE_TERMINATE, i)
            try:
                slave.terminate()
            except Exception as exc:  # a failing terminate must not hide the run's own outcome
                self.log.message(slave.name, "warning", f"terminate failed: {exc}")
        for slave in self.slaves:
            if slave is None or slave.error_status >= FATAL:
                continue
            try:
                slave.free()
            except Exception as exc:
                self.log.message(slave.name, "warning", f"freeInstance failed: {exc}")


def _same(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    if a.dtype == object:
        return bool(np.all(a == b)) if len(a) else True
    if a.dtype.kind == "f":
        if not len(a):
            return True
        with np.errstate(invalid="ignore"):      # inf - inf: equal infinities (and NaN beside NaN) have settled
            close = (a == b) | (np.abs(a - b) <= tol * np.maximum(1.0, np.abs(b))) | (np.isnan(a) & np.isnan(b))
        return bool(np.all(close))
    return bool(np.array_equal(a, b))
