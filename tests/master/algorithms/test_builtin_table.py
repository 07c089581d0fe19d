"""The built-in algorithm table (``master.algorithms.BUILTIN``) against what the modules of the folder register, and
what a look-up imports: the one module it names."""
import ast
import subprocess
import sys

# a fresh interpreter: the test process may have registered algorithms of its own (tests/master/test_execution.py)
EVERY_MODULE = """
import importlib, pkgutil
import master.algorithms as pkg
from master.algorithms import ALGORITHMS, BUILTIN
for info in pkgutil.iter_modules(pkg.__path__):
    importlib.import_module("master.algorithms." + info.name)
registered = {name: cls.__module__ for name, cls in ALGORITHMS.load_all().items()}
print(repr((registered, dict(BUILTIN))))
"""

LOOK_UP = """
import sys
from master.algorithms import ALGORITHMS
assert "ecco" in ALGORITHMS and "no-such" not in ALGORITHMS
before = set(sys.modules)
ALGORITHMS.get("jacobi")
print(" ".join(sorted(m for m in set(sys.modules) - before if m.startswith("master.algorithms."))))
"""


def _run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout


def test_the_table_names_every_algorithm_the_folder_registers_and_its_module():
    registered, table = ast.literal_eval(_run(EVERY_MODULE))
    assert registered == table


def test_a_look_up_imports_the_module_of_that_name_only():
    # jacobi's module and what it imports itself (its base class); no other algorithm, and "in" imports nothing
    assert _run(LOOK_UP).split() == ["master.algorithms.jacobi"]
