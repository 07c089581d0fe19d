"""A run's initialization and outputs: the connection-graph orders worked out once per graph (compared with the
ordering functions on random graphs), no disk reserve when no sink writes into the run folder, and the Parquet
module left unimported by what does not write Parquet."""
import random
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pyarrow as pa
import pytest

from master.algorithms.ordering import algebraic_loops, gauss_seidel_order
from master.execution import _GRAPH_ORDERS, _graph_orders
from master.plan import Link, Var
from master.sinks.group import RESERVE_NAME, SinkGroup
from master.sinks.memory import MemorySink
from master.sinks.parquet import ParquetSink

ROOT = Path(__file__).resolve().parents[2]


def _var(comp, name, causality):
    return Var(comp, name, 0, "Real", "Real", causality, "continuous", None)


def _random_plan(rng: random.Random, n: int):
    """A plan as the ordering functions read it: links between the outputs and inputs of n components, and each
    output's declared dependencies (None: on every input, as an FMU declaring none)."""
    names = [f"c{i}" for i in range(n)]
    outs = {c: [f"y{k}" for k in range(rng.randint(1, 3))] for c in names}
    ins = {c: [f"u{k}" for k in range(rng.randint(1, 3))] for c in names}
    links, taken = [], set()
    for _ in range(rng.randint(0, 3 * n)):
        a, b = rng.choice(names), rng.choice(names)
        y, u = rng.choice(outs[a]), rng.choice(ins[b])
        if (b, u) in taken:
            continue
        taken.add((b, u))
        links.append(Link(_var(a, y, "output"), _var(b, u, "input")))
    feed = {c: {y: None if rng.random() < 0.3 else set(rng.sample(ins[c], rng.randint(0, len(ins[c]))))
                for y in outs[c]} for c in names}
    return SimpleNamespace(links=links, feedthrough=feed), names


def test_graph_orders_equal_the_ordering_functions_on_random_graphs():
    rng = random.Random(20261127)
    _GRAPH_ORDERS.clear()
    plans = [_random_plan(rng, rng.randint(1, 6)) for _ in range(400)]
    for rounds in range(2):           # the second round answers from the cache
        for plan, names in plans:
            loops, order = _graph_orders(plan, names)
            assert loops == algebraic_loops(plan)
            assert order == gauss_seidel_order(plan, names).order
    # the same links with other declared dependencies is another graph: loops appear and go
    plan, names = _random_plan(random.Random(3), 4)
    for c in names:
        for y in plan.feedthrough[c]:
            plan.feedthrough[c][y] = None
    assert _graph_orders(plan, names)[0] == algebraic_loops(plan)
    for c in names:
        for y in plan.feedthrough[c]:
            plan.feedthrough[c][y] = set()
    assert _graph_orders(plan, names)[0] == algebraic_loops(plan) == []


def test_graph_orders_hand_each_run_lists_of_its_own():
    a, b = _var("a", "y", "output"), _var("b", "u", "input")
    c, d = _var("b", "y", "output"), _var("a", "u", "input")
    plan = SimpleNamespace(links=[Link(a, b), Link(c, d)], feedthrough={"a": {"y": None}, "b": {"y": None}})
    expected = (algebraic_loops(plan), gauss_seidel_order(plan, ["a", "b"]).order)
    assert len(expected[0]) == 1 and len(expected[0][0]) == 4       # one loop through both components
    loops, order = _graph_orders(plan, ["a", "b"])
    assert (loops, order) == expected
    loops[0].append("changed")
    order.reverse()
    assert _graph_orders(plan, ["a", "b"]) == expected


SCHEMA = pa.schema([("time", pa.float64())])


def test_no_reserve_without_a_sink_writing_into_the_folder(tmp_path, monkeypatch):
    made = []
    real_open = open

    def spy(path, *a, **k):
        if Path(str(path)).name == RESERVE_NAME:
            made.append(path)
        return real_open(path, *a, **k)
    monkeypatch.setattr("builtins.open", spy)
    g = SinkGroup([MemorySink()], tmp_path)
    g.open(SCHEMA)
    g.write(pa.table({"time": [0.0, 1.0]}))
    g.close()
    assert made == [] and list(tmp_path.iterdir()) == []
    # a sink writing into the folder keeps its reserve while the run records (given back at close)
    g = SinkGroup([ParquetSink(), MemorySink()], tmp_path)
    g.open(SCHEMA)
    assert made and (tmp_path / RESERVE_NAME).stat().st_size == 4 << 20
    g.write(pa.table({"time": [0.0, 1.0]}))
    g.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.parquet"]
    import pyarrow.parquet as pq
    assert pq.read_table(tmp_path / "results.parquet")["time"].to_pylist() == [0.0, 1.0]


def test_the_sink_registry_leaves_pyarrow_parquet_unimported():
    """A campaign worker keeps its rows in memory: importing every sink module must not import pyarrow.parquet
    (with pyarrow.fs and ssl)."""
    code = ("import sys; from master.sinks import SINKS; SINKS.names(); SINKS.get('memory'); SINKS.get('parquet');"
            "print(sorted(m for m in ('pyarrow.parquet', 'pyarrow.fs', 'ssl') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "[]"


def test_slave_class_looked_up_once_per_module_and_model_identifier():
    import types

    from pythonfmu import Fmi2Slave

    from master.fmi import inprocess
    mod = types.ModuleType("runend_two_slaves")
    for name in ("First", "Second"):
        setattr(mod, name, type(name, (Fmi2Slave,), {"__module__": mod.__name__}))
    assert inprocess._slave_class(mod, "Second") is mod.Second
    assert inprocess._slave_class(mod, "First") is mod.First
    assert inprocess._slave_class(mod, "Third") is None            # two candidates, none of that name
    mod.Third = type("Third", (Fmi2Slave,), {"__module__": mod.__name__})
    assert inprocess._slave_class(mod, "Second") is mod.Second       # as first found: a module is imported once
    assert inprocess._slave_class(mod, "Third") is None


def test_plan_vars_finds_what_plan_var_finds():
    """Random component and variable names with dots in them: the same Var, or the same error."""
    from master.errors import ScenarioError
    from master.execution import _plan_vars
    from master.plan import Plan
    rng = random.Random(7)
    parts = ["a", "b", "c", "x"]
    for _ in range(300):
        comps = {".".join(rng.choices(parts, k=rng.randint(1, 3))) for _ in range(rng.randint(1, 4))}
        variables = {c: {".".join(rng.choices(parts, k=rng.randint(1, 2))): None for _ in range(3)} for c in comps}
        for c in variables:
            for n in variables[c]:
                variables[c][n] = _var(c, n, "output")
        plan = Plan(None, "test.ssd", {}, [], [], {}, variables)
        for _ in range(20):
            q = ".".join(rng.choices(parts + [""], k=rng.randint(1, 5)))
            try:
                expected = plan.var(q)
            except ScenarioError as exc:
                try:
                    _plan_vars(plan, [q])
                except ScenarioError as mine:
                    assert str(mine) == str(exc)
                else:
                    raise AssertionError(f"{q!r}: plan.var raised {exc}, _plan_vars did not")
                continue
            assert _plan_vars(plan, [q]) == [expected]
            assert _plan_vars(plan, [q])[0] is expected
