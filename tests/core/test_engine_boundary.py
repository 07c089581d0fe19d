"""The engine stands alone: nothing under master/ imports the UAV study (uavstudy) or its models (uavsim);
they reach the engine through entry points only."""
import ast
import subprocess
import sys
from pathlib import Path

MASTER = Path(__file__).resolve().parents[2] / "master"
STUDY = ("uavstudy", "uavsim")

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


def _imported(tree) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                "import_module", "__import__") and node.args and isinstance(node.args[0], ast.Constant):
            names.add(str(node.args[0].value))
    return names


def test_no_engine_source_imports_the_study():
    offenders = []
    for f in sorted(MASTER.rglob("*.py")):
        for name in _imported(ast.parse(f.read_text(encoding="utf-8"))):
            if name.split(".")[0] in STUDY:
                offenders.append(f"{f.relative_to(MASTER.parent)}: {name}")
    assert offenders == []
