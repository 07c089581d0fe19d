"""Fixed-step co-simulation algorithms behind one small interface (see base.Algorithm)."""
from .base import Algorithm
from .gauss_seidel import GaussSeidel
from .jacobi import Jacobi

ALGORITHMS: dict[str, type[Algorithm]] = {"jacobi": Jacobi, "gauss-seidel": GaussSeidel}


def get_algorithm(name: str) -> Algorithm:
    try:
        return ALGORITHMS[name]()
    except KeyError:
        from ..errors import CosimError
        raise CosimError(f"unknown algorithm {name!r} (known: {', '.join(ALGORITHMS)})", element="--algorithm") from None
