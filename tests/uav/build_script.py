"""fmu_sources/build_fmus.py loaded as a module (it is a script, not part of a package)."""
import importlib.util
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "fmu_sources"


def build_fmus_module():
    spec = importlib.util.spec_from_file_location("uav_build_fmus", SRC / "build_fmus.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
