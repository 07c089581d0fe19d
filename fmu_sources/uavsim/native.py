"""The CPython extension modules of uavsim: ``_<name>_ext.c`` next to this file, compiled by
``fmu_sources/build_fmus.py`` against the stable ABI (``<name>.abi3.so``, any CPython >= 3.9).

They run a model's whole FMU step (inputs read from the shell, the model advanced, outputs written back)
without a Python frame per variable.  Each one has a Python twin that stays the reference: an extension is
used only where it gives bit-identical results (tests compare the two), and wherever it is absent (no
compiler at build time, another platform or interpreter) or ``UAVSIM_PURE_PYTHON=1`` is set, the Python
code runs instead, only slower.
"""
from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from pathlib import Path

SUFFIX = ".abi3.so"
_HERE = Path(__file__).resolve().parent
_loaded: dict = {}       # path -> module (None: it did not load)


def disabled() -> bool:
    return os.environ.get("UAVSIM_PURE_PYTHON", "") not in ("", "0")


def load_extension(name: str, *folders):
    """The extension module ``name`` (e.g. "_dynamics_ext") from the first of (*folders, this package's
    folder) that holds ``name.abi3.so`` and can load it; None when none can (the caller's Python twin).
    An FMU shell names its own resources first: the library built with the FMU matches the sources it bundles."""
    if disabled():
        return None
    for folder in (*map(Path, folders), _HERE):
        path = str(Path(folder) / (name + SUFFIX))
        if path in _loaded:
            if _loaded[path] is not None:
                return _loaded[path]
            continue
        if not os.path.isfile(path):
            continue
        module = None
        try:
            loader = importlib.machinery.ExtensionFileLoader(f"uavsim.{name}", path)
            spec = importlib.util.spec_from_file_location(f"uavsim.{name}", path, loader=loader)
            module = importlib.util.module_from_spec(spec)
            loader.exec_module(module)
        except (ImportError, OSError):       # another platform, architecture or an older build
            module = None
        _loaded[path] = module
        if module is not None:
            return module
    return None
