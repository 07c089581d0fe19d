"""Helpers of the campaign tests (a uniquely named module: conftest.py files are not importable by name)."""
import os
from contextlib import contextmanager
from pathlib import Path

from master.ssp.writer import SspBuilder


def write_chain_ssp(path: Path, fmus: dict, k: float = 1.0) -> Path:
    """src (Faulty: y = time; mode 3 aborts in doStep after fail_time) -> gain (y = k u) -> integ."""
    b = SspBuilder("chain")
    b.stop, b.step = 1.0, 0.1
    b.add_component("src", fmus["faulty"], params={"fail_time": 0.5, "mode": 0})
    b.add_component("gain", fmus["gain"], params={"k": float(k)})
    b.add_component("integ", fmus["integ"], params={"a": 0.0, "x0": 0.0})
    b.connect("src", "y", "gain", "u")
    b.connect("gain", "y", "integ", "u")
    b.record = ["src.y", "gain.y", "integ.y"]
    return b.write(path)


@contextmanager
def local_cluster(**kwargs):
    """A Dask ``distributed.LocalCluster(**kwargs)`` that leaves this process's environment as it found it.

    Each of its nannies runs in this process and, before it spawns its worker, writes the worker's
    ``distributed.nanny.pre-spawn-environ`` (OMP/MKL/OPENBLAS_NUM_THREADS=1, MALLOC_TRIM_THRESHOLD_,
    PYTHONHASHSEED) into ``os.environ`` and never takes it back: every later test's commands inherited one BLAS
    thread and a fixed hash seed, and the program server, which keys its servers on ``PYTHON*``, started a second
    one.  The workers get these variables all the same (the nanny hands them its own copy)."""
    import distributed
    saved = dict(os.environ)
    try:
        with distributed.LocalCluster(**kwargs) as cluster:
            yield cluster
    finally:
        for name in set(os.environ) - set(saved):
            del os.environ[name]
        for name, value in saved.items():
            if os.environ.get(name) != value:
                os.environ[name] = value
