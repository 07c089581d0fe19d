"""Orders derived from the connection graph: the Gauss-Seidel stepping order and algebraic loops.

Everything here is deterministic: ties are broken by the components' order of declaration.
"""
from __future__ import annotations

from ..plan import Plan
from ..records import Record


class StepOrder(Record):
    """A plain class, not a dataclass (``master.records`` says why)."""
    def __init__(self, order: list[int], broken: list[tuple[str, str]] | None = None):
        self.order = order                                      # component indices in stepping order
        self.broken = [] if broken is None else broken          # connections that read a value of the previous step


def _sccs(n: int, succ: list[set[int]]) -> list[list[int]]:
    """Tarjan's algorithm, iterative; components listed in order of discovery from index 0 upwards."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in range(n):
        if root in index:
            continue
        work = [(root, iter(sorted(succ[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(succ[w]))))
                    advanced = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp))
    return out


def component_graph(plan: Plan, names: list[str]) -> list[set[int]]:
    idx = {n: i for i, n in enumerate(names)}
    succ = [set() for _ in names]
    for ln in plan.links:
        a, b = idx[ln.src.component], idx[ln.dst.component]
        if a != b:
            succ[a].add(b)
    return succ


def gauss_seidel_order(plan: Plan, names: list[str]) -> StepOrder:
    """Topological order of the component graph; inside a cycle, greedily step first the component with
    the fewest unmet inputs from the cycle (ties: declaration order), and report the connections that then
    carry a value from the previous step."""
    n = len(names)
    succ = component_graph(plan, names)
    pred = [set() for _ in range(n)]
    for a in range(n):
        for b in succ[a]:
            pred[b].add(a)
    sccs = _sccs(n, succ)
    comp_of = {}
    for k, c in enumerate(sccs):
        for v in c:
            comp_of[v] = k
    # Kahn on the condensation, smallest first member first
    cpred = [set() for _ in sccs]
    for a in range(n):
        for b in succ[a]:
            if comp_of[a] != comp_of[b]:
                cpred[comp_of[b]].add(comp_of[a])
    ready = sorted((min(c), k) for k, c in enumerate(sccs) if not cpred[k])
    done_c, order = set(), []
    import heapq
    heapq.heapify(ready)
    remaining = [set(p) for p in cpred]
    while ready:
        _, k = heapq.heappop(ready)
        done_c.add(k)
        members = set(sccs[k])
        placed: list[int] = []
        while members:
            best = min(members, key=lambda v: (len((pred[v] & members)), v))
            placed.append(best)
            members.discard(best)
        order.extend(placed)
        for k2, r in enumerate(remaining):
            if k in r:
                r.discard(k)
                if not r and k2 not in done_c and all(k2 != kk for _, kk in ready):
                    heapq.heappush(ready, (min(sccs[k2]), k2))
    pos = {v: p for p, v in enumerate(order)}
    broken = sorted({(ln.src.qualified, ln.dst.qualified) for ln in plan.links
                     if ln.src.component != ln.dst.component
                     and pos[names.index(ln.src.component)] > pos[names.index(ln.dst.component)]})
    return StepOrder(order, broken)


def algebraic_loops(plan: Plan) -> list[list[str]]:
    """Strongly connected sets of instantaneous dependencies: connection edges plus each FMU's declared output
    dependencies (an output without a declaration depends on every input of its FMU)."""
    names, succ, _ = _dependency_graph(plan)
    return [[names[v] for v in comp] for comp in _sccs(len(names), succ) if len(comp) > 1]


def loop_cycles(plan: Plan) -> list[list[tuple[str, str, str]]]:
    """One shortest cycle through each algebraic loop, as its edges (from, to, how): how is "connection",
    "declared" (the FMU declares that output to depend on that input) or "assumed" (the FMU declares no
    dependencies for the output, so every input counts)."""
    names, succ, how = _dependency_graph(plan)
    cycles = []
    for comp in _sccs(len(names), succ):
        if len(comp) < 2:
            continue
        inside, start = set(comp), comp[0]
        prev, frontier, found = {start: None}, [start], None
        while frontier and found is None:       # breadth first: the shortest way back to the start
            nxt = []
            for v in frontier:
                for w in sorted(succ[v]):
                    if w == start:
                        found = v
                        break
                    if w in inside and w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found is not None:
                    break
            frontier = nxt
        path, v = [start], found
        while v is not None and v != start:
            path.insert(1, v)
            v = prev[v]
        path.append(start)
        cycles.append([(names[a], names[b], how[(a, b)]) for a, b in zip(path, path[1:])])
    return cycles


def _dependency_graph(plan: Plan):
    nodes: dict[str, int] = {}

    def node(q):
        return nodes.setdefault(q, len(nodes))
    how: dict[tuple[int, int], str] = {}
    inputs_of: dict[str, list[str]] = {}
    for ln in plan.links:
        how[(node(ln.src.qualified), node(ln.dst.qualified))] = "connection"
        inputs_of.setdefault(ln.dst.component, []).append(ln.dst.name)
    for ln in plan.links:
        comp = ln.src.component
        deps = plan.feedthrough.get(comp, {}).get(ln.src.name, None)
        ins = inputs_of.get(comp, [])
        for name in ins:
            if deps is None or name in deps:
                how.setdefault((node(f"{comp}.{name}"), node(ln.src.qualified)), "assumed" if deps is None
                               else "declared")
    n = len(nodes)
    succ = [set() for _ in range(n)]
    for a, b in how:
        succ[a].add(b)
    return sorted(nodes, key=nodes.get), succ, how
