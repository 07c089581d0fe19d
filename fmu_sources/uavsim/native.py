"""The compiled accelerators of uavsim: how they are built, found and switched off (one place for all of them).

The Python code of this package is the reference: the plain models a reader follows (dynamics.py, battery.py,
wind.py, kernels.py's loops, strategy.py).  Each C file beside it is an accelerator of one of them, declared with
the reference it replaces in :mod:`uavsim.accelerators` and checked against it, bit for bit, by the project's one
harness (tests/accelerators/):

- ``kernels.c`` (a shared library loaded with ctypes by :mod:`uavsim.kernels`): the dynamics' flying sub-steps
  and the battery's whole step;
- ``_<name>_ext.c`` (CPython extension modules, built against the stable ABI as ``<name>.abi3.so``): a shell's
  whole FMU step (UavDynamics, UavBattery, UavWind, UavStrategy).

Where an accelerator is absent (no compiler, another platform or interpreter) or ``COSIM_MASTER_PURE_PYTHON=1`` is
set, the Python code runs instead, only slower.  Every one is compiled by the project's one build path,
``master.native_build``, with the same flags: inside an FMU by ``fmu_sources/build_fmus.py`` at FMU build time
(into the FMU's ``resources/uavsim/``); outside an FMU (tests, benchmarks) on first use into the per-user cache,
when ``master`` is importable.  Code bundled into an FMU never needs ``master``: there the import fails and the
library built with the FMU serves.
"""
from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from pathlib import Path

#: the one variable that switches every accelerator off (master/accel.py ENV; read here without importing master)
ENV = "COSIM_MASTER_PURE_PYTHON"
SUFFIX = ".abi3.so"
#: -ffp-contract=off: no fused multiply-add, so the compiled code rounds exactly as the Python references
FLAGS = ["-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math", "-std=c99"]
#: the extensions are built against the stable ABI: one build serves every CPython >= 3.9
LIMITED_API = "0x03090000"
CACHE_FOLDER = "uavsim"
_HERE = Path(__file__).resolve().parent
_loaded: dict = {}       # path -> module (None: it did not load)


def disabled() -> bool:
    """True when ``COSIM_MASTER_PURE_PYTHON`` is set to anything but "" or "0"."""
    return os.environ.get(ENV, "") not in ("", "0")


def load_extension(name: str, *folders):
    """The extension module ``name`` (e.g. "_dynamics_ext") from the first of (*folders, this package's
    folder) that holds ``name.abi3.so`` and can load it; None when none can (the caller's Python twin).
    An FMU shell names its own resources first: the library built with the FMU matches the sources it bundles."""
    if disabled():
        return None
    for folder in (*map(Path, folders), _HERE):
        module = _load_module(name, Path(folder) / (name + SUFFIX))
        if module is not None:
            return module
    return None


def _load_module(name: str, path: Path):
    key = str(path)
    if key in _loaded:
        return _loaded[key]
    if not path.is_file():
        return None
    try:
        loader = importlib.machinery.ExtensionFileLoader(f"uavsim.{name}", key)
        spec = importlib.util.spec_from_file_location(f"uavsim.{name}", key, loader=loader)
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except (ImportError, OSError):       # another platform, architecture or an older build
        module = None
    _loaded[key] = module
    return module


# ------------------------------------------------------------------ building (master.native_build)

def extension_build(name: str, src_dir: Path | str = _HERE) -> tuple[Path, list, bytes] | None:
    """(source, compiler flags, what else the build depends on) of the extension ``name`` in ``src_dir``; None
    without Python's headers.  fmu_sources/build_fmus.py builds the FMUs' copies with exactly these."""
    import sysconfig
    include = sysconfig.get_paths().get("include", "")
    if not os.path.isfile(os.path.join(include, "Python.h")):
        return None
    source = Path(src_dir) / f"{name}.c"
    flags = [*FLAGS, f"-DPy_LIMITED_API={LIMITED_API}", f"-I{include}", f"-I{source.parent}"]
    return source, flags, (source.parent / "kernels.c").read_bytes()      # an extension may #include kernels.c


def build(source: Path, stem: str, flags: list, *, suffix: str = ".so", depends: bytes = b""):
    """``source`` compiled by master.native_build into the per-user cache: (path, None) or (None, why not).
    Without ``master`` (code bundled into an FMU) nothing is built: the FMU carries its libraries."""
    try:
        from master.native_build import compile_cached
    except ImportError:
        return None, "master.native_build is not importable here (an FMU carries the libraries built with it)"
    return compile_cached(Path(source), stem, CACHE_FOLDER, list(flags), suffix=suffix,
                          key_text=depends + Path(source).read_bytes())


def build_extension(name: str):
    """The extension ``name`` built here (outside an FMU) and loaded: (module, None) or (None, why not)."""
    if disabled():
        return None, f"{ENV} is set"
    spec = extension_build(name)
    if spec is None:
        return None, "no Python.h: the extensions cannot be built here"
    source, flags, depends = spec
    path, why = build(source, name.lstrip("_"), flags, suffix=SUFFIX, depends=depends)
    if path is None:
        return None, why
    module = _load_module(name, path)
    return (module, None) if module is not None else (None, f"{path.name} does not load")
