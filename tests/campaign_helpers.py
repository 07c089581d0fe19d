"""Helpers of the campaign tests (a uniquely named module: conftest.py files are not importable by name)."""
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
