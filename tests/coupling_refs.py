"""The references shipped beside the coupling SSPs (ssp/coupling/oscillator_exact.py, oscillator_step_map.py,
loop2_exact.py, quarter_car_exact.py), loaded by path: they are scripts next to the archives, not a package."""
from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

COUPLING = Path(__file__).resolve().parents[1] / "ssp" / "coupling"


@functools.lru_cache(maxsize=None)
def coupling_reference(name: str):
    """The module ``ssp/coupling/<name>.py``, loaded once per test session."""
    spec = importlib.util.spec_from_file_location(f"coupling_reference_{name}", COUPLING / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
