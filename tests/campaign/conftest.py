"""Fixtures of the campaign tests: a small generic SSP (Faulty -> Gain -> Integrator) built from the
test FMUs, and a writer of campaign files around it."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1]))
import fmu_factory  # noqa: E402

from master.ssp.writer import SspBuilder  # noqa: E402


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


@pytest.fixture(scope="session")
def chain_fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("campaign_fmus")
    return {"faulty": fmu_factory.build_by_key("c2:Faulty", root),
            "gain": fmu_factory.build_by_key("c2:Gain", root),
            "integ": fmu_factory.build_by_key("py:Integrator", root)}


@pytest.fixture
def chain_ssp(tmp_path, chain_fmus):
    return write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)
