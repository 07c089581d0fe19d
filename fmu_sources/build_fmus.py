"""Build the UAV FMUs (pythonfmu) into fmus/, bundling the uavsim package (and sitlsim for UavSitl).

    python fmu_sources/build_fmus.py [--dest DIR] [--check]

Each FMU's resources/ holds the shell script (e.g. UavDynamics.py), the package uavsim/ (all its
*.py files and C sources; the shells put resources/ first on sys.path, so the bundled copy is used),
the compiled accelerators ``uavsim/_uavsim_kernels.so`` and ``uavsim/_<name>_ext.abi3.so`` (and
``sitlsim/_sitlsim_physics.so`` for UavSitl), built by the project's one build path, master.native_build (the
C compiler, ``$CC``, cc or gcc, into the per-user cache, copied from there; without one the FMUs run the
bit-identical Python references, only slower: uavsim/native.py) and
``sources.sha256``: one line "<sha256>  <path relative to fmu_sources/>" per bundled source file.
``stale_fmus(fmu_dir, src_dir)`` compares those lists with the current files, so a test can detect
a shipped FMU that was not rebuilt after a source change (``--check`` does the same from the
command line and exits 1 when something is stale).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
FMU_NAMES = ("UavDynamics", "UavBattery", "UavWind", "UavStrategy", "UavSitl", "UavChannel")
#: FMU -> extra packages bundled besides uavsim (with their C sources, compiled here like kernels.c)
EXTRA_PACKAGES = {"UavSitl": ("sitlsim",)}
#: FMUs without FMI get/set state (the others mix in uavsim.fmi.StateMixin)
NO_STATE = ("UavSitl",)
#: package -> its C source (relative to the package)
C_SOURCES = {"uavsim": "kernels.c", "sitlsim": "physics.c"}
HASH_FILE = "sources.sha256"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def bundled_sources(name: str, src_dir: Path | str = HERE) -> list[str]:
    """Paths (relative to src_dir, '/'-separated) of the source files bundled into FMU ``name``."""
    src_dir = Path(src_dir)
    files = [f"{name}.py"]
    files += sorted(f"uavsim/{p.name}" for p in (src_dir / "uavsim").glob("*.py"))
    files += ["uavsim/kernels.c"]
    files += sorted(f"uavsim/{p.name}" for p in (src_dir / "uavsim").glob(EXTENSION_GLOB))
    for pkg in EXTRA_PACKAGES.get(name, ()):
        files += sorted(f"{pkg}/{p.name}" for p in (src_dir / pkg).glob("*.py"))
        if (src_dir / pkg / C_SOURCES[pkg]).is_file():
            files.append(f"{pkg}/{C_SOURCES[pkg]}")
    return files


#: CPython extension sources of uavsim (uavsim/native.py), each built as <stem>.abi3.so against the stable ABI
EXTENSION_GLOB = "_*_ext.c"


def _copy_built(built: tuple, dest: Path, name: str) -> Path | None:
    """The (path, why not) of a build by master.native_build (through the package's own build function, so that
    the FMUs and the tests share one cached build) copied to ``dest``; None (and a warning) without a compiler; a
    compiler error stops the build."""
    path, why = built
    if path is None:
        if why and why.startswith("the C compiler failed"):
            raise SystemExit(f"compiling {name} failed: {why}")
        print(f"warning: {why}; the FMUs will run the Python references of {name}", file=sys.stderr)
        return None
    shutil.copyfile(path, dest)
    return dest


def compile_extensions(dest_dir: Path | str, src_dir: Path | str = HERE) -> list[Path]:
    """Compile every uavsim/_*_ext.c into dest_dir/<stem>.abi3.so (they may #include "kernels.c"); none (and a
    warning) without a compiler or Python's headers: the FMUs then run the Python references."""
    from uavsim import native
    out = []
    for src in sorted((Path(src_dir) / "uavsim").glob(EXTENSION_GLOB)):
        spec = native.extension_build(src.stem, src.parent)
        if spec is None:
            print("warning: no Python.h; the FMUs will run the Python references of the extensions", file=sys.stderr)
            return []
        source, flags, depends = spec
        built = native.build(source, src.stem.lstrip("_"), flags, suffix=native.SUFFIX, depends=depends)
        target = _copy_built(built, Path(dest_dir) / (src.stem + native.SUFFIX), src.name)
        if target is None:
            return []
        out.append(target)
    return out


def compile_kernels(dest_dir: Path | str, src_dir: Path | str = HERE) -> Path | None:
    """Compile uavsim/kernels.c into dest_dir/_uavsim_kernels.so; None (and a warning) without a compiler."""
    from uavsim import kernels, native
    source = Path(src_dir) / "uavsim" / "kernels.c"
    return _copy_built(native.build(source, kernels.LIBRARY[1:-3], native.FLAGS), Path(dest_dir) / kernels.LIBRARY,
                       source.name)


def compile_physics(dest_dir: Path | str, src_dir: Path | str = HERE) -> Path | None:
    """Compile sitlsim/physics.c into dest_dir/_sitlsim_physics.so; None (and a warning) without a compiler."""
    from sitlsim import physics
    source = Path(src_dir) / "sitlsim" / "physics.c"
    return _copy_built(physics.build_library(source), Path(dest_dir) / physics.LIBRARY, source.name)


def source_hashes(name: str, src_dir: Path | str = HERE) -> dict[str, str]:
    src_dir = Path(src_dir)
    return {rel: _sha256(src_dir / rel) for rel in bundled_sources(name, src_dir)}


def format_hashes(hashes: dict[str, str]) -> str:
    return "".join(f"{h}  {rel}\n" for rel, h in sorted(hashes.items()))


def parse_hashes(text: str) -> dict[str, str]:
    out = {}
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        h, rel = line.split(None, 1)
        out[rel.strip()] = h
    return out


def shipped_hashes(fmu: Path | str) -> dict[str, str] | None:
    try:
        with zipfile.ZipFile(fmu) as z:
            return parse_hashes(z.read(f"resources/{HASH_FILE}").decode("utf-8"))
    except (FileNotFoundError, KeyError, zipfile.BadZipFile):
        return None


def stale_fmus(fmu_dir: Path | str = REPO / "fmus", src_dir: Path | str = HERE) -> list[str]:
    """Names (e.g. "UavDynamics.fmu") of the FMUs in fmu_dir that are missing, carry no
    sources.sha256, or whose bundled sources differ from the current files in src_dir."""
    stale = []
    for name in FMU_NAMES:
        fmu = Path(fmu_dir) / f"{name}.fmu"
        shipped = shipped_hashes(fmu)
        if shipped is None or shipped != source_hashes(name, src_dir):
            stale.append(fmu.name)
    return stale


def build_fmu(name: str, dest: Path | str, src_dir: Path | str = HERE) -> Path:
    """Build one FMU into dest/<name>.fmu and return its path."""
    from pythonfmu.builder import FmuBuilder

    src_dir = Path(src_dir).resolve()
    dest = Path(dest).resolve()
    dest.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f"build_{name}_") as tmp:
        stage = Path(tmp)
        packages = ("uavsim", *EXTRA_PACKAGES.get(name, ()))
        for p in packages:
            (stage / p).mkdir()
        for rel in bundled_sources(name, src_dir):
            if "/" in rel:
                shutil.copy2(src_dir / rel, stage / rel)
        (stage / HASH_FILE).write_text(format_hashes(source_hashes(name, src_dir)))
        if str(src_dir) not in sys.path:
            sys.path.insert(0, str(src_dir))
        compile_kernels(stage / "uavsim", src_dir)
        compile_extensions(stage / "uavsim", src_dir)
        if "sitlsim" in packages and (stage / "sitlsim" / "physics.c").is_file():
            compile_physics(stage / "sitlsim", src_dir)
        out = FmuBuilder.build_FMU(src_dir / f"{name}.py", dest=dest / f"{name}.fmu",
                                   project_files=[*(stage / p for p in packages), stage / HASH_FILE],
                                   # uavsim.fmi.StateMixin; a SITL process cannot be saved and restored
                                   canGetAndSetFMUstate=name not in NO_STATE)
    from reproducible import make_reproducible
    return make_reproducible(out)


def build_all(dest: Path | str = REPO / "fmus", src_dir: Path | str = HERE) -> list[Path]:
    return [build_fmu(n, dest, src_dir) for n in FMU_NAMES]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dest", default=str(REPO / "fmus"), help="output folder (default fmus/)")
    ap.add_argument("--check", action="store_true", help="only report stale FMUs (exit 1 if any)")
    a = ap.parse_args(argv)
    if a.check:
        stale = stale_fmus(a.dest, HERE)
        print("stale: " + (", ".join(stale) if stale else "none"))
        return 1 if stale else 0
    for p in build_all(a.dest, HERE):
        print(f"built {p}")
    stale = stale_fmus(a.dest, HERE)
    if stale:
        print("still stale after build: " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
