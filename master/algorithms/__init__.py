"""Co-simulation algorithms behind one interface (see base.Algorithm), in one registry.

Each built-in algorithm is a module of this folder that registers it when imported
(``@ALGORITHMS.register("name")``) and a line in ``BUILTIN`` naming that module, so that a run imports the one
algorithm it uses (importing them all cost every start ~30 ms; tests/master/algorithms/test_builtin_table.py holds
the table to what the modules register); other packages publish theirs under the ``cosim_master.algorithms``
entry point group. The CLI, the SSD settings annotation and campaigns all read this registry.
"""
from ..registry import Registry
from .base import Algorithm

#: name -> module of every built-in algorithm
BUILTIN = {name: f"{__name__}.{module}" for name, module in (
    ("adaptive", "adaptive"), ("ecco", "ecco"), ("gauss-seidel", "gauss_seidel"), ("iterative", "iterative"),
    ("jacobi", "jacobi"))}

ALGORITHMS: Registry[type[Algorithm]] = Registry("algorithm", "cosim_master.algorithms", builtins=BUILTIN)


def get_algorithm(name: str, element: str = "--algorithm") -> Algorithm:
    return ALGORITHMS.get(name, element=element)()


__all__ = ["ALGORITHMS", "Algorithm", "get_algorithm"]
