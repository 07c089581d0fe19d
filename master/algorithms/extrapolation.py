"""Polynomial input extrapolation for the fixed-step algorithms (``--extrapolation K``, Busch 2016).

An FMU holds each input constant over its step, so what matters is the constant it is given. With hold (K = 0)
it gets y_n, the coupled output at the step's start: the input lags the signal by half a step on average, a
local error O(h^2) per step and a global error O(h). Here each coupled Real output is replaced, for the step
[t_n, t_n + h], by the *mean over that step* of the polynomial through its last K + 1 samples y_n ... y_{n-K}
(times t_n, t_n - h, ...). For K = 1 that mean is the value at the step's midpoint, 3/2 y_n - 1/2 y_{n-1}; for
K = 2 it is (23 y_n - 16 y_{n-1} + 5 y_{n-2}) / 12 (the Adams-Bashforth weights, for the same reason). The
mean is the constant that makes the input's integral over the step right to O(h^{K+2}); a constant input
still misses the input's slope within the step (O(h^3) locally), so the global order is 2 for K = 1 and
K = 2, and 1 for K = 0. Extrapolating to the step's start gives y_n again (hold); to its end (2 y_n - y_{n-1})
errs by half a step the other way: order 1 as well.

The samples must be values at the communication points. A direct-feedthrough output read after a step
reflects the input set before that step (see docs/architecture.md): with hold that is today's semantics, but
as a sample for extrapolation it is half a step off. So after each step the components with a coupled
feedthrough output get their inputs from the new outputs and are read again (one pass in Gauss-Seidel
order: enough for feedthrough chains, not solving algebraic loops), which makes the samples consistent.
The step's inputs are then set from the extrapolated values as usual. That read-after-set is outside FMI's
co-simulation calling sequence (see ``InputExtrapolation.refresh``): it gives consistent samples only with FMUs
whose getters evaluate their outputs from the inputs last set.

Outputs of components on a step multiple (k > 1) and of components taken out are held, as without
extrapolation. The first steps use the samples there are (order 0, then 1, ...).

Input derivatives (``--input-derivatives 1``, Jacobi): an FMU that can interpolate its inputs (FMI 2.0
canInterpolateInputs) is given the extrapolation polynomial itself rather than a constant: the value at the
step's start (y_n, through which the polynomial passes) and its derivatives there of orders 1..K
(fmi2SetRealInputDerivatives), so its input follows the polynomial within the step. The input then errs by
O(h^{K+1}) throughout the step instead of O(h) (a constant misses the slope), the local error is O(h^{K+2}) and
the global order K + 1: 2 for K = 1 and 3 for K = 2 (docs/coupling.md). Every receiver of such an output must
be able to interpolate; one that cannot is named in a one-line error before the first step.

Per output (``extrapolation_for``, ``--extrapolate A.x=1``, the SSD connection annotation read by
ssp/connection_extrapolation.py): the order belongs to the coupled *output*, not to each connection, because the
value extrapolated is the output's sample history and every connection from it reads the same buffer entry;
two receivers of one output cannot be given different constants for the same step without a buffer per
connection. Outputs not named take the global order. Gauss-Seidel interpolation (``--gs-interpolation M``) is
in gs_interpolation.py; it uses the same history.
"""
from __future__ import annotations

import math
from collections import deque
from functools import lru_cache

import numpy as np

from ..errors import CosimError, ScenarioError
from ..fmi.slave import WARNING
from .ordering import gauss_seidel_order


def coupled_outputs(rt) -> tuple[np.ndarray, dict[int, int]]:
    """The positions in ``rt.out["Real"]`` of the outputs that feed step inputs, from active components that
    step every master step (outputs of a component on a step multiple are staged and held), sorted; and the
    component each comes from."""
    owner = {}
    for j, (a, _) in enumerate(rt.out_slice["Real"]):
        if rt.active[j] and rt.multiple[j] == 1:
            owner.update((p, j) for p in range(a, a + rt.step_reads(j, "Real")))
    fed = {int(p) for i in range(len(rt.names)) if rt.active[i]
           for p in rt.src["Real"][slice(*rt.in_slice["Real"][i])]}
    positions = np.array(sorted(p for p in fed if p in owner), dtype=np.intp)
    return positions, {int(p): owner[int(p)] for p in positions}


@lru_cache(maxsize=None)
def step_mean_weights(samples: int, ratio: float = 1.0) -> tuple[float, ...]:
    """Weights w_j of y_{n-j}, j < samples, giving the mean over [t_n, t_n + ratio h] of the polynomial
    through the samples at t_n - j h."""
    return interval_mean_weights(tuple(-np.arange(samples, dtype=float)), ratio)


@lru_cache(maxsize=None)
def hermite_derivative_weights(samples: int, order: int) -> tuple[float, ...]:
    """Weights of (y_n, ..., y_{n-samples+1}, h y'_n) giving h^order times the order-th derivative at t_n of the
    polynomial of degree ``samples`` through the samples at t_n - j h with the slope y'_n at t_n."""
    nodes = -np.arange(samples, dtype=float)
    rows = [nodes ** k for k in range(samples + 1)]               # p(-j) = sum_k c_k (-j)^k
    system = np.vstack([np.array(rows).T, np.eye(samples + 1)[1]])  # p'(0) = c_1
    coefficients = np.linalg.inv(system)                             # data -> c
    return tuple(float(v) for v in math.factorial(order) * coefficients[order]) if order <= samples else \
        (0.0,) * (samples + 1)


@lru_cache(maxsize=None)
def derivative_weights(samples: int, order: int) -> tuple[float, ...]:
    """Weights w_j of y_{n-j}, j < samples, giving h^order times the order-th derivative at t_n of the
    polynomial through the samples at t_n - j h (0 beyond the polynomial's degree)."""
    from numpy.polynomial import polynomial as P
    nodes = -np.arange(samples, dtype=float)
    weights = []
    for j in range(samples):
        others = np.delete(nodes, j)
        basis = P.polyfromroots(others) / np.prod(nodes[j] - others)
        weights.append(float(P.polyval(0.0, P.polyder(basis, order))) if order < samples else 0.0)
    return tuple(weights)


def interval_mean_weights(nodes: tuple, ratio: float) -> tuple[float, ...]:
    """Weights of the samples at ``nodes`` (in steps from t_n) giving the mean over [t_n, t_n + ratio h] of
    the polynomial through them (the Lagrange basis integrated exactly)."""
    from numpy.polynomial import polynomial as P
    nodes = np.array(nodes, dtype=float)
    weights = []
    for j in range(len(nodes)):
        others = np.delete(nodes, j)
        basis = P.polyfromroots(others) / np.prod(nodes[j] - others)
        antiderivative = P.polyint(basis)
        weights.append(float(P.polyval(ratio, antiderivative) - P.polyval(0.0, antiderivative)) / ratio)
    return tuple(weights)


class InputExtrapolation:
    """Wraps a compiled fixed-step step: coupled outputs replaced by their extrapolation while the inputs are
    set, consistent samples taken after it."""

    def __init__(self, rt, plan, order: int, per_output: dict | None = None, keep: int = 0,
                 derivatives_step: float | None = None, slopes: bool = False):
        """``per_output``: output name -> its order (the others: ``order``); ``keep``: samples kept at least
        (Gauss-Seidel interpolation reads some of its own); ``derivatives_step``: the master step, when the
        receivers get the polynomial as value and derivatives (input derivatives) instead of its step mean."""
        self.rt, self.plan, self.order = rt, plan, order
        self.per_output = dict(per_output or {})
        self.derivatives_step = derivatives_step
        self.slopes = slopes        # the polynomial also matches the producers' output derivatives at t_n
        self.resync = lambda: None  # re-reads what the wrapper keeps of the FMUs' state (the slopes)
        self.refresh_order = gauss_seidel_order(plan, rt.names).order
        self.positions = np.zeros(0, dtype=np.intp)
        self.history: deque = deque(maxlen=max([order, keep - 1, *self.per_output.values()]) + 1)

    def describe(self) -> dict:
        info = {"order": self.order, "to": "mean over the step (K = 1: its midpoint)",
                "weights": list(step_mean_weights(self.order + 1))}
        if self.per_output:
            info["per_output"] = dict(sorted(self.per_output.items()))
        if self.derivatives_step is not None:
            info["to"] = "the polynomial itself: value and derivatives at the step's start (input derivatives)"
            info.pop("weights")
        return info

    def around(self, step, ratio: float = 1.0):
        """The step with extrapolated inputs (``ratio``: its length in master steps)."""
        self.select()
        if self.derivatives_step is not None:
            return self._with_derivatives(step)
        out, pos, history = self.rt.out["Real"], self.positions, self.history
        groups = []         # (indices into pos or None for all of them, weights by number of samples)
        for k, idx in self._order_groups():
            groups.append((idx, [np.array(step_mean_weights(m, ratio)) for m in range(1, k + 2)]))

        def extrapolated_step(n, t):
            for idx, weights in groups:
                w = weights[min(len(history), len(weights)) - 1]
                if idx is None:
                    out[pos] = w @ np.array(history)[:len(w)] if len(w) > 1 else history[0]
                elif len(w) > 1:
                    out[pos[idx]] = w @ np.array(history)[:len(w), idx]
            step(n, t)
            self.refresh(t)
            history.appendleft(out[pos].copy())
        return extrapolated_step

    def _with_derivatives(self, step):
        """The step with every receiver of an extrapolated output given the polynomial's derivatives at the
        step's start (its inputs keep y_n, the sample the transfers copy)."""
        rt, pos, history, h = self.rt, self.positions, self.history, self.derivatives_step
        out = rt.out["Real"]
        orders = self._orders()
        degree = orders + (1 if self.slopes else 0)        # of the polynomial each output's receivers get
        top = int(degree.max()) if len(degree) else 0
        slot = {int(p): j for j, p in enumerate(pos)}
        receivers = {}          # component index -> [(input vr, slot in pos, factor)]
        for ln in self.plan.links:
            if (ln.src is None or ln.dst.causality != "input" or ln.dst.type != "Real"
                    or not rt.active[rt.index[ln.dst.component]]):
                continue
            j = slot.get(rt.out_pos.get(ln.src.qualified, -1))
            if j is not None and degree[j] > 0:
                receivers.setdefault(rt.index[ln.dst.component], []).append((ln.dst.vr, j, ln.factor))
        feeds = []
        for i, entries in sorted(receivers.items()):
            slave = rt.slaves[i]
            if not slave.can_interpolate_inputs:
                raise CosimError(f"{rt.names[i]} cannot interpolate inputs (canInterpolateInputs is not true), so "
                                 "it cannot be given input derivatives", file=self.plan.shown_as,
                                 element="--input-derivatives")
            # per order d = 1..K of each input: the input's slot and factor (orders above its own K give 0)
            rows = [(d, vr, j, factor) for d in range(1, top + 1) for vr, j, factor in entries]
            put = slave.input_derivatives_setter([vr for _, vr, _, _ in rows], [d for d, *_ in rows])
            feeds.append((i, put, np.array([j for _, _, j, _ in rows], dtype=np.intp),
                          np.array([d for d, *_ in rows]), np.array([f for *_, f in rows])))
        if self.slopes:
            weights = {(m, d): np.array(hermite_derivative_weights(m, d)) for m in range(1, top + 1)
                       for d in range(1, top + 1)}
            slope, read_slopes = self._slope_reader(feeds)
            read_slopes(0.0)
            self.resync = lambda: read_slopes(0.0)    # after a restored state (a caller that rolls back)
        else:
            weights = {(m, d): np.array(derivative_weights(m, d)) for m in range(1, top + 2)
                       for d in range(1, top + 1)}

        def derivative_step(n, t):
            samples = np.array(history)
            for i, put, js, ds, factors in feeds:
                values = np.zeros(len(js))
                for k, (j, d) in enumerate(zip(js, ds)):
                    m = min(len(samples), int(orders[j]) + 1)
                    if self.slopes:     # m samples and the slope: degree m
                        if d <= m:
                            data = np.append(samples[:m, j], h * slope[j])
                            values[k] = weights[(m, int(d))] @ data / h ** int(d) * factors[k]
                    elif d < m:
                        values[k] = weights[(m, int(d))] @ samples[:m, j] / h ** int(d) * factors[k]
                if (st := put(values)) > WARNING:
                    raise rt.slaves[i].fail("setting input derivatives", st, t)
            step(n, t)
            self.refresh(t)
            if self.slopes:
                read_slopes(t)
            history.appendleft(out[pos].copy())
        return derivative_step

    def _slope_reader(self, feeds):
        """(slope, read): the first derivatives of the coupled outputs at the current communication point, read
        by ``read(t)`` from their producers (fmi2GetRealOutputDerivatives). A producer with a coupled
        feedthrough output first gets its inputs' slopes (its output's derivative depends on them), in the
        consistent-sample order, after the producers it reads from."""
        rt, pos = self.rt, self.positions
        name_at = {p: q for q, p in rt.out_pos.items()}
        slope = np.zeros(len(pos))
        by_producer = {}
        for j, p in enumerate(pos):
            by_producer.setdefault(self.owner[int(p)], []).append(j)
        through = [i for i, _ in self.refreshed]
        getters = {}
        for i, js in by_producer.items():
            slave = rt.slaves[i]
            if slave.max_output_derivative_order < 1:
                raise CosimError(f"{rt.names[i]} gives no output derivatives (maxOutputDerivativeOrder is 0), so "
                                 "its outputs' slopes are unknown", file=self.plan.shown_as,
                                 element="--input-derivatives 2")
            vrs = [self.plan.var(name_at[int(pos[j])]).vr for j in js]
            getters[i] = (slave.output_derivatives_getter(vrs, [1] * len(vrs)), np.array(js, dtype=np.intp))
        slope_feeds = {i: (put, js, ds, factors) for i, put, js, ds, factors in feeds}
        order = [i for i in getters if i not in through] + [i for i in through if i in getters or i in slope_feeds]

        def read(t):
            for i in order:
                if i in through and i in slope_feeds:       # its inputs' slopes first
                    put, js, ds, factors = slope_feeds[i]
                    if (st := put(np.where(ds == 1, slope[js] * factors, 0.0))) > WARNING:
                        raise rt.slaves[i].fail("setting input derivatives", st, t)
                if i in getters:
                    get, js = getters[i]
                    st, values = get()
                    if st > WARNING:
                        raise rt.slaves[i].fail("getting output derivatives", st, t)
                    slope[js] = values
        return slope, read

    def _orders(self) -> np.ndarray:
        name_at = {p: q for q, p in self.rt.out_pos.items()}
        return np.array([self.per_output.get(name_at.get(int(p)), self.order) for p in self.positions], dtype=int)

    def _order_groups(self) -> list[tuple[int, np.ndarray | None]]:
        """The coupled outputs by order: one group (None: every position) when they share one, as with the
        global order alone, so that the arithmetic is the same as without per-output orders."""
        name_at = {p: q for q, p in self.rt.out_pos.items()}
        orders = np.array([self.per_output.get(name_at.get(int(p)), self.order) for p in self.positions], dtype=int)
        if len(set(orders.tolist())) <= 1:
            return [(int(orders[0]) if len(orders) else self.order, None)]
        return [(int(k), np.flatnonzero(orders == k)) for k in sorted(set(orders.tolist()))]

    # -- which values, which components ------------------------------------------------------------------
    def select(self) -> None:
        """Positions in out["Real"] of coupled outputs of active components stepping every step, and the
        components whose coupled outputs have direct feedthrough; history restarts when they change."""
        rt = self.rt
        positions, owner = coupled_outputs(rt)
        self.owner = owner
        feeds = {rt.names[owner[p]] for p in positions}
        through = {ln.src.component for ln in self.plan.links
                   if ln.src.component in feeds and ln.dst.causality == "input" and self._feeds_through(ln.src)}
        self.refreshed = [(i, rt.fast_ops(i)) for i in self.refresh_order if rt.names[i] in through]
        if not np.array_equal(positions, self.positions) or not self.history:
            self.positions = positions
            self.history.clear()
            self.history.append(rt.out["Real"][positions].copy())

    def _feeds_through(self, output) -> bool:
        deps = self.plan.feedthrough.get(output.component, {}).get(output.name)
        return deps is None or len(deps) > 0        # None: no declaration, so it depends on every input

    def refresh(self, t: float) -> None:
        """Inputs of the feedthrough components from the new outputs, and their outputs read again.

        This sets inputs and gets outputs with no doStep between them, which FMI's co-simulation calling
        sequence does not allow: FMI 2.0 (4.2.4, state slaveInitialized) forbids fmi2GetXXX after fmi2SetXXX
        without an fmi2DoStep in between, because a co-simulation FMU computes in fmi2DoStep and not in its
        getters, and FMI 3.0 keeps that rule in Step Mode. The ModelStructure's dependencies, which decide
        which components are refreshed, say what an output depends on, not that a getter re-evaluates it.
        What the second read gives depends on the FMU:
        - getters that evaluate the outputs from the inputs last set (this project's C and Python FMUs): the
          consistent sample the extrapolation needs (docs/coupling.md, "Consistent samples": order 2 with K = 1
          on the two-mass oscillator instead of 1);
        - outputs fixed by the last doStep: the same values again, so the samples are those of a run without
          the refresh, at the price of one set and one get per refreshed component and step;
        - an FMU that enforces the rule: an error status, which ends the run with one line naming it.
        Only runs that ask for it pay this (extrapolation K > 0, per-output orders, input derivatives; the
        adaptive algorithm with extrapolation or an error estimate that reads held inputs; iterative coupling
        with interpolated inputs); plain fixed-step runs, every shipped SSP among them, never call it. Kept
        because without it a feedthrough output's sample is half a step off and the extrapolation's order drops
        to 1."""
        for i, (transfers, setters, _, getters, _) in self.refreshed:
            for x in transfers:
                x()
            for op, what in [(s, "setting inputs") for s in setters] + [(g, "getting outputs") for g in getters]:
                if (st := op()) > WARNING:
                    raise self.rt.slaves[i].fail(what, st, t)


def per_output_orders(plan, given: dict | None, caller: str) -> tuple[dict, dict]:
    """The per-output extrapolation orders of a run: those of the SSD's connection annotations, replaced per
    output by ``given`` (the API's ``extrapolation_for`` or ``--extrapolate``). Returns name -> order and
    name -> where it came from; a one-line error for an unknown name, an output that feeds no Real input, an
    order outside 0..2, or two connections from one output with different orders."""
    orders, sources = {}, {}
    for conn in plan.model.connections:
        k = getattr(conn, "extrapolation", None)
        if k is None:
            continue
        where = f"Connection {conn.src} -> {conn.dst}"
        if conn.src in orders and orders[conn.src] != k:
            raise ScenarioError(f"the connections from {conn.src} ask for extrapolation orders {orders[conn.src]} "
                                f"and {k}; the order belongs to the output (docs/coupling.md)",
                                file=plan.shown_as, element=where, line=conn.line)
        _check_coupled_real_output(plan, conn.src, lambda reason: ScenarioError(
            reason, file=plan.shown_as, element=where, line=conn.line))
        orders[conn.src], sources[conn.src] = k, f"SSD {where}"
    for name, k in (given or {}).items():
        element = f"--extrapolate {name}"
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k not in (0, 1, 2):
            raise CosimError(f"the order must be 0, 1 or 2, not {k!r}", element=element)
        _check_coupled_real_output(plan, str(name), lambda reason: CosimError(reason, element=element))
        orders[str(name)], sources[str(name)] = int(k), caller
    return orders, sources


def _check_coupled_real_output(plan, name: str, error) -> None:
    try:
        var = plan.var(name)
    except (KeyError, ValueError, CosimError):
        raise error(f"unknown variable {name!r}") from None
    if var.causality != "output" or var.type != "Real" or not any(
            ln.src is not None and ln.src.qualified == var.qualified for ln in plan.links):
        raise error(f"{name} is not a coupled Real output (only a Real output connected to an input is "
                    "extrapolated)")
