"""fmu_sources/build_fmus.py loaded as a module (it is a script, not part of a package)."""
import importlib.util
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "fmu_sources"


def build_fmus_module():
    spec = importlib.util.spec_from_file_location("uav_build_fmus", SRC / "build_fmus.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def load_shell(name: str):
    """An instance of the FMU shell fmu_sources/<name>.py (e.g. "UavStrategy") run in this process."""
    spec = importlib.util.spec_from_file_location(f"shell_{name}", SRC / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return getattr(mod, name)(instance_name="t", resources=str(SRC), visible=False)
