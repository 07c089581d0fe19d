"""Build the UAV FMUs (pythonfmu) into fmus/, bundling the uavsim package (and sitlsim for UavSitl).

    python fmu_sources/build_fmus.py [--dest DIR] [--check]

Each FMU's resources/ holds the shell script (e.g. UavDynamics.py), the package uavsim/ (all its
*.py files and kernels.c; the shells put resources/ first on sys.path, so the bundled copy is used),
the compiled kernels ``uavsim/_uavsim_kernels.so`` (built here with the C compiler, ``$CC`` or gcc;
without one the FMUs run the bit-identical Python twins, only slower: uavsim/kernels.py) and
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
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
FMU_NAMES = ("UavDynamics", "UavBattery", "UavWind", "UavStrategy", "UavSitl")
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


#: -ffp-contract=off: no fused multiply-add, so the compiled kernels round exactly as the Python twins
KERNEL_FLAGS = ["-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math", "-std=c99"]


#: CPython extension sources of uavsim (uavsim/native.py), each built as <stem>.abi3.so against the stable ABI
EXTENSION_GLOB = "_*_ext.c"
LIMITED_API = "0x03090000"


def compile_extensions(dest_dir: Path | str, src_dir: Path | str = HERE) -> list[Path]:
    """Compile every uavsim/_*_ext.c into dest_dir/<stem>.abi3.so (they may #include "kernels.c"); none (and a
    warning) without a compiler or Python's headers: the FMUs then run the Python twins."""
    import sysconfig
    from uavsim.native import SUFFIX
    include = sysconfig.get_paths().get("include", "")
    sources = sorted((Path(src_dir) / "uavsim").glob(EXTENSION_GLOB))
    if not sources:
        return []
    if not os.path.isfile(os.path.join(include, "Python.h")):
        print(f"warning: no Python.h in {include!r}; the FMUs will run the Python twins of the extensions",
              file=sys.stderr)
        return []
    cc = os.environ.get("CC", "gcc")
    out = []
    for src in sources:
        target = Path(dest_dir) / (src.stem + SUFFIX)
        cmd = [cc, *KERNEL_FLAGS, f"-DPy_LIMITED_API={LIMITED_API}", f"-I{include}", f"-I{src.parent}",
               "-o", str(target), str(src), "-lm"]
        try:
            subprocess.run(cmd, check=True, capture_output=True, text=True)
        except FileNotFoundError:
            print(f"warning: no C compiler ({cc}); the FMUs will run the Python twins", file=sys.stderr)
            return []
        except subprocess.CalledProcessError as exc:
            raise SystemExit(f"compiling {src.name} failed: {' '.join(cmd)}\n{exc.stderr}") from None
        out.append(target)
    return out


def compile_kernels(dest_dir: Path | str, src_dir: Path | str = HERE) -> Path | None:
    """Compile uavsim/kernels.c into dest_dir/_uavsim_kernels.so; None (and a warning) without a compiler."""
    from uavsim.kernels import LIBRARY
    out = Path(dest_dir) / LIBRARY
    cc = os.environ.get("CC", "gcc")
    cmd = [cc, *KERNEL_FLAGS, "-o", str(out), str(Path(src_dir) / "uavsim" / "kernels.c"), "-lm"]
    try:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    except FileNotFoundError:
        print(f"warning: no C compiler ({cc}); the FMUs will run the Python kernels", file=sys.stderr)
        return None
    except subprocess.CalledProcessError as exc:
        raise SystemExit(f"compiling the kernels failed: {' '.join(cmd)}\n{exc.stderr}") from None
    return out


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
            from sitlsim.physics import compile_library
            compile_library(stage / "sitlsim", stage / "sitlsim" / "physics.c")
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
