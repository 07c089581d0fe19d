"""C sources of the master and its extensions compiled on first use, once per content, into the per-user cache.

No build step at install and no new dependency: the system's C compiler ($CC, cc or gcc) builds a shared
library (or a CPython extension module) the first time it is needed; the file name carries a hash of the
sources, flags and platform, so an edited source is rebuilt and parallel workers share one build (each writes a
temporary file and renames it: whoever finishes last leaves a whole file).  Without a compiler the caller gets the
reason and runs its Python twin.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def cache_dir(name: str) -> Path:
    from .cache_paths import cache_root
    return cache_root() / name


def compile_cached(source: Path, stem: str, folder: str, flags: list, *, suffix: str = ".so",
                   key_text: bytes | None = None, what: str = "",
                   build_flags=None) -> tuple[Path | None, str | None]:
    """``source`` compiled with ``flags`` into the cache folder ``folder`` as ``<stem>-<hash><suffix>``:
    (path, None), or (None, why not).  ``key_text``: what the build depends on (default: the source).
    ``build_flags``: a function giving more flags, or raising ``NoBuild``, called only for a build (what they
    depend on must be in ``key_text``)."""
    key_text = source.read_bytes() if key_text is None else key_text
    key = hashlib.sha256(key_text + " ".join(flags).encode() + sys.platform.encode()).hexdigest()[:16]
    target = cache_dir(folder) / f"{stem}-{key}{suffix}"
    if target.is_file():
        return target, None
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        return None, "no C compiler found ($CC, cc, gcc)"
    if build_flags is not None:
        try:
            flags = [*flags, *build_flags()]
        except NoBuild as exc:
            return None, str(exc)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(suffix=suffix, dir=target.parent)
        os.close(fd)
        proc = subprocess.run([cc, *flags, "-o", tmp, str(source), "-lm"], capture_output=True, text=True)
        if proc.returncode != 0:
            os.unlink(tmp)
            first = (proc.stderr.strip().splitlines() or ["(no message)"])[0]
            return None, f"the C compiler failed: {first}"
        os.replace(tmp, target)
    except OSError as exc:
        return None, f"cannot compile {what or source.name}: {exc}"
    return target, None


class NoBuild(Exception):
    """Why a build cannot be made here (``compile_cached``'s ``build_flags``)."""


def _python_headers() -> list[str]:
    import sysconfig
    include = sysconfig.get_paths().get("include", "")
    if not os.path.isfile(os.path.join(include, "Python.h")):
        raise NoBuild(f"no Python.h in {include!r}")
    return [f"-I{include}"]


def compile_extension(source: Path, module: str, folder: str, flags: list, *, depends: bytes = b""):
    """``source`` built as a CPython extension module ``module`` for this interpreter and imported:
    (module, None), or (None, why not).  ``depends``: the content of files it includes."""
    # the interpreter is named in the key by its ABI (the extension suffix) and its installation (whose include
    # folder holds the headers), so that sysconfig (~1.5 ms, on every run's path) is asked only for a build
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    path, why = compile_cached(source, module.lstrip("_"), folder, [*flags, f"-I{source.parent}"], suffix=suffix,
                               key_text=depends + source.read_bytes() + suffix.encode() + sys.base_prefix.encode()
                               + sys.version.encode(), build_flags=_python_headers)
    if path is None:
        return None, why
    try:
        loader = importlib.machinery.ExtensionFileLoader(module, str(path))
        spec = importlib.util.spec_from_file_location(module, str(path), loader=loader)
        mod = importlib.util.module_from_spec(spec)
        loader.exec_module(mod)
    except (ImportError, OSError) as exc:
        return None, f"cannot load {path.name}: {exc}"
    return mod, None
