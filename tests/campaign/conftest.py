"""Fixtures of the campaign tests: the test FMUs of a small generic SSP (Faulty -> Gain -> Integrator)."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1]))
sys.path.insert(0, str(Path(__file__).parent))
import fmu_factory  # noqa: E402


@pytest.fixture(scope="session")
def chain_fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("campaign_fmus")
    return {"faulty": fmu_factory.build_by_key("c2:Faulty", root),
            "gain": fmu_factory.build_by_key("c2:Gain", root),
            "integ": fmu_factory.build_by_key("py:Integrator", root)}
