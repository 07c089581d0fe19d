"""Fixtures of the campaign tests: the test FMUs of a small generic SSP (Faulty -> Gain -> Integrator)."""
import fmu_factory
import pytest


@pytest.fixture(scope="session")
def chain_fmus(tmp_path_factory):
    root = tmp_path_factory.mktemp("campaign_fmus")
    return {"faulty": fmu_factory.build_by_key("c2:Faulty", root),
            "gain": fmu_factory.build_by_key("c2:Gain", root),
            "integ": fmu_factory.build_by_key("py:Integrator", root)}
