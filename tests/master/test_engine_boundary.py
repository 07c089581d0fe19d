"""The engine's boundaries, read from its source.

1. The engine stands alone: nothing under master/ imports the UAV study (uavstudy) or its models (uavsim,
   sitlsim); they reach the engine through entry points only.

2. master/ is a stack of layers, each importing only from layers below it (or beside it, where allowed):

   ====  ==========================================================================================================
   L0    foundations: errors, values, units, registry, yamlio, interrupts, _version, cache_paths, accel,
         algorithm_options, arrow_numpy -- import nothing of master/ but each other
   L1    ssp/* (reading SSPs) | fmi/* (loading and calling FMUs) | native_build; ssp/ and fmi/ never import each
         other: what both need (the cache root, the file hash) is in cache_paths (L0)
   L2    plan/* (the SSD checked against the FMUs); ssp/writer (SSP authoring: it reads the FMUs' descriptions
         through fmi/cache to write their connectors, so it sits above both readers; nothing below imports it)
   L3    runtime
   L4    algorithms/*, observers/*, monitors/*, sinks/*, live, manipulators, settings (resolving a run's settings
         names the algorithm, so it sits beside the algorithms; the SSD reader below returns the name as text);
         an algorithm sees only the runtime: algorithms/ imports no observer, monitor, sink or live stream
   L5    execution, results, drivers/* (the step drivers of an execution)
   L6    runner, supervise, inspect_scenario, step_accelerators (the step accelerators' declarations for the
         harness run whole executions)
   L7    campaign/*, study/*, scenario_kinds
   L8    cli, master/__init__ (the package face: it may import anything; nothing imports its names)
   ====  ==========================================================================================================

   This is the cut the code shows (docs/architecture.md, "Layers"). It differs from the sketch issue 24 started
   from in two places: settings is at L4, not L2, and ssp/writer at L2, not L1, for the reasons given above.

3. There is no import circle: the module graph has no strongly connected component of more than one module.

How the imports are found (``imports_of``): every .py file under master/ is parsed with ``ast`` and every import
anywhere in it counts, at module level or inside a function, class or ``if TYPE_CHECKING:`` block:
``import a.b``, ``from a import b`` (relative forms resolved against the importing module's package; ``b`` is the
module ``a.b`` when there is one, else a name of ``a``), and ``importlib.import_module("...")`` /
``__import__("...")`` called with a string constant (a relative one resolved with its ``package=``). Each target is
mapped to the innermost module of master/ that defines it (``master.plan.build`` for ``master.plan.build.x``).
Two refinements follow Python's import semantics:
- ``from PACKAGE import name`` where ``name`` is not a module imports the package's ``__init__``: that is an edge to
  the package itself (so ``from master import __version__`` is an import of the L8 face, and is refused);
- ``import master`` from inside master/ executes nothing new (a package is imported before any of its modules), so
  it counts by what is read from it: ``master.x.y`` is an import of the module ``master.x.y``, ``master.run`` of the
  face; ``master.__file__`` (a module attribute, not a name of the face) is nothing.
Not seen, by design: the registries' loaders (``registry.import_submodules``, entry points) that import plugin
modules by computed names; a built-in plugin registers itself in a registry below it, as an installed package's
plugins do.
"""
import ast
import functools
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MASTER = ROOT / "master"
STUDY = ("uavstudy", "uavsim", "sitlsim")

# -- 1. the engine stands alone -------------------------------------------------------------------------------------
IMPORT_ALL = """
import importlib, pkgutil, sys
import master
for info in pkgutil.walk_packages(master.__path__, "master."):
    importlib.import_module(info.name)
print(" ".join(sorted(m for m in sys.modules if m.split(".")[0] in {study!r})))
"""


def test_importing_every_engine_module_imports_no_study_module():
    out = subprocess.run([sys.executable, "-c", IMPORT_ALL.format(study=set(STUDY))], capture_output=True,
                         text=True, check=True)
    assert out.stdout.strip() == ""


# -- the import graph ------------------------------------------------------------------------------------------------
def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES: dict[str, Path] = {_module_name(f): f for f in sorted(MASTER.rglob("*.py"))}


def _is_package(module: str) -> bool:
    return module in MODULES and MODULES[module].name == "__init__.py"


def _owner(name: str) -> str | None:
    """The innermost module of master/ that ``name`` (a module or a name in one) belongs to."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _resolve(module: str, level: int, name: str | None) -> str:
    """The absolute name of ``from <level dots><name> import ...`` written in ``module``."""
    if not level:
        return name or ""
    package = module if _is_package(module) else module.rpartition(".")[0]
    parts = package.split(".")
    base = ".".join(parts[:len(parts) - level + 1])
    return f"{base}.{name}" if name else base


def _dotted(node) -> str | None:
    """``a.b.c`` of an attribute chain on a plain name, else None."""
    names = []
    while isinstance(node, ast.Attribute):
        names.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id, *reversed(names)])


def _reads_of_package(tree, bound: str, package: str) -> list[tuple[int, str]]:
    """What a module that did ``import <package>`` (an ancestor of it) reads from it: (line, target) per read."""
    reads = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and not isinstance(getattr(node, "parent", None), ast.Attribute):
            chain = _dotted(node)
            if chain is None or chain.split(".")[0] != bound:
                continue
            attr = chain.split(".")[1]
            if attr.startswith("__") and attr.endswith("__"):
                continue
            full = package + chain[len(bound):]
            reads.append((node.lineno, _owner(full) or package))
    return reads


def imports_of(module: str, source: str | None = None) -> list[tuple[int, str]]:
    """(line, imported module of master/) for every import in ``module``'s source (see the module docstring)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8") if source is None else source)
    for node in ast.walk(tree):
        for child in ast.iter_child_nodes(node):
            child.parent = node
    found = []
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            for alias in node.names:
                ancestor = alias.asname is None and alias.name in MODULES and module.startswith(alias.name + ".")
                if ancestor:
                    found += _reads_of_package(tree, alias.name, alias.name)
                else:
                    targets.append(alias.name)
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(module, node.level, node.module)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.append(sub if sub in MODULES else base)
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) and isinstance(
                node.args[0].value, str) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                "import_module", "__import__"):
            name = node.args[0].value
            if name.startswith("."):
                package = next((k.value.value for k in node.keywords if k.arg == "package"
                                and isinstance(k.value, ast.Constant)), "")
                level = len(name) - len(name.lstrip("."))
                name = _resolve(package + ".__init__" if package else module, level, name.lstrip(".") or None)
            targets.append(name)
        for target in targets:
            owner = _owner(target)
            if owner is not None:
                found.append((node.lineno, owner))
    return sorted({(line, target) for line, target in found if target != module})


@functools.cache         # read once for the tests that walk it (none changes it)
def import_graph() -> dict[str, dict[str, int]]:
    """module -> {imported module: first line that imports it}."""
    graph = {}
    for module in MODULES:
        edges: dict[str, int] = {}
        for line, target in imports_of(module):
            edges.setdefault(target, line)
        graph[module] = edges
    return graph


def _where(module: str, line: int) -> str:
    return f"{MODULES[module].relative_to(ROOT)}:{line}"


# -- 2. layers -------------------------------------------------------------------------------------------------------
#: module or package (covering its modules) -> layer; "master" is the package face only
LAYERS = {
    # L0 foundations
    "master.errors": 0, "master.values": 0, "master.units": 0, "master.registry": 0, "master.yamlio": 0,
    "master.interrupts": 0, "master._version": 0, "master.cache_paths": 0, "master.accel": 0,
    "master.algorithm_options": 0,
    "master.arrow_numpy": 0,
    "master.scratch": 0,
    "master.log": 0, "master.records": 0,
    # L1 reading the scenario | loading the FMUs
    "master.ssp": 1, "master.fmi": 1, "master.native_build": 1,
    # L2 the plan; SSP authoring
    "master.plan": 2, "master.ssp.writer": 2,
    # L3
    "master.runtime": 3,
    # L4 what acts on the running system
    "master.algorithms": 4, "master.observers": 4, "master.monitors": 4, "master.sinks": 4, "master.live": 4,
    "master.manipulators": 4, "master.settings": 4,
    # L5 one run
    "master.execution": 5, "master.results": 5, "master.drivers": 5,
    # L6 running it
    "master.runner": 6, "master.supervise": 6, "master.inspect_scenario": 6,
    "master.step_accelerators": 6,     # the step accelerators' declarations run whole executions
    "master.stability": 6,             # identifies a step map by running executions
    # L7 many runs
    "master.campaign": 7, "master.study": 7, "master.scenario_kinds": 7,
    # L8 the faces
    "master.cli": 8, "master": 8,
}

#: same-layer imports that are refused: (importer's package, imported package) -- either way for ssp/fmi
FORBIDDEN_BESIDE = [
    ("master.ssp", "master.fmi"), ("master.fmi", "master.ssp"),
    *((("master.algorithms", other) for other in ("master.observers", "master.monitors", "master.sinks",
                                                  "master.live", "master.manipulators"))),
]

def layer_of(module: str) -> int | None:
    if module in LAYERS:
        return LAYERS[module]
    name = module
    while "." in name:
        name = name.rpartition(".")[0]
        if name in LAYERS and name != "master":
            return LAYERS[name]
    return None


def _in(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def test_every_module_has_a_layer_and_every_entry_names_a_module():
    assert [m for m in MODULES if layer_of(m) is None] == []
    assert [k for k in LAYERS if k not in MODULES] == []


def test_no_module_imports_from_a_layer_above_it_or_beside_it_where_refused():
    offenders = []
    for module, edges in import_graph().items():
        for target, line in edges.items():
            mine, theirs = layer_of(module), layer_of(target)
            if target == "master":
                offenders.append(f"{_where(module, line)}: {module} imports a name of the package face "
                                 "master/__init__: import it from the module that defines it")
            elif theirs > mine:
                offenders.append(f"{_where(module, line)}: {module} (L{mine}) imports {target} (L{theirs})")
            elif theirs == mine and any(_in(module, a) and _in(target, b) for a, b in FORBIDDEN_BESIDE):
                offenders.append(f"{_where(module, line)}: {module} imports {target} beside it (L{mine}), "
                                 "which the layers refuse")
    assert offenders == [], "imports against the layers:\n" + "\n".join(offenders)


def strongly_connected(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """Tarjan's strongly connected components of more than one module (iterative: the graph is ~100 deep)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(graph.get(child, {}))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def _a_cycle(graph: dict[str, dict[str, int]], component: list[str]) -> str:
    """One circle through the component, each step with the line that makes it."""
    members = set(component)
    start = component[0]
    path, seen = [start], {start}
    while True:
        node = path[-1]
        nxt = next((t for t in graph[node] if t == start and len(path) > 1), None) or \
            next((t for t in graph[node] if t in members and t not in seen), None) or \
            next(t for t in graph[node] if t in members)
        if nxt in seen:
            path = path[path.index(nxt):] + [nxt]
            break
        path.append(nxt)
        seen.add(nxt)
    return " -> ".join(f"{a} ({_where(a, graph[a][b])})" for a, b in zip(path, path[1:])) + f" -> {path[-1]}"


def test_the_import_graph_has_no_circle():
    graph = import_graph()
    circles = [f"{len(c)} modules in a circle ({', '.join(c)}), e.g. {_a_cycle(graph, c)}"
               for c in strongly_connected(graph)]
    assert circles == [], "import circles:\n" + "\n".join(circles)


SOURCE_WITH_HIDDEN_IMPORTS = """
import master
from . import model
from .model import Unit


def f():
    from ..scenario_kinds import kind_claiming
    import importlib
    importlib.import_module("master.fmi.cache")
    importlib.import_module(".table", package="master.fmi")
    from .. import __version__, interrupts
    return master.__file__, master.run, master.plan.build.build_plan
"""


def test_the_analysis_sees_function_level_relative_and_string_imports():
    """The checks above are only as good as the import finder: it must see the kinds of import that hide."""
    found = imports_of("master.ssp.parser", SOURCE_WITH_HIDDEN_IMPORTS)
    assert found == [(3, "master.ssp.model"), (4, "master.ssp.model"), (8, "master.scenario_kinds"),
                     (10, "master.fmi.cache"), (11, "master.fmi.table"), (12, "master"), (12, "master.interrupts"),
                     (13, "master"), (13, "master.plan.build")]
    assert _resolve("master.plan.build", 1, "model") == "master.plan.model"
    assert _resolve("master.plan", 1, "build") == "master.plan.build"
    graph = {"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}
    assert strongly_connected(graph) == [["a", "b", "c"]]


# -- 1 again, from the source: also imports the subprocess above never executes ------------------------------------
def test_no_engine_source_imports_the_study():
    offenders = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                    "import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant):
                names = [str(node.args[0].value)]
            offenders += [f"{_where(module, node.lineno)}: {n}" for n in names if n.split(".")[0] in STUDY]
    assert offenders == []
