"""Co-simulation algorithms behind one interface (see base.Algorithm), in one registry.

Each module of this folder registers its algorithm when imported (``@ALGORITHMS.register("name")``), so a
new built-in algorithm is one new file; other packages publish theirs under the ``cosim_master.algorithms``
entry point group. The CLI, the SSD settings annotation and campaigns all read this registry.
"""
from ..registry import Registry, import_submodules
from .base import Algorithm

ALGORITHMS: Registry[type[Algorithm]] = Registry("algorithm", "cosim_master.algorithms",
                                                 builtins=import_submodules(__name__))


def get_algorithm(name: str, element: str = "--algorithm") -> Algorithm:
    return ALGORITHMS.get(name, element=element)()


__all__ = ["ALGORITHMS", "Algorithm", "get_algorithm"]
