"""A campaign is checked when its file is loaded, not by running every run into a failure: each parameter
set against its scenario (through the scenario kind), and a file of the wrong kind says what it is."""
from pathlib import Path

import pytest

from campaign_helpers import write_chain_ssp
from master.campaign.spec import load_campaign
from master.cli import main
from master.errors import ScenarioError

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "ssp" / "scenarios"


def write(folder: Path, text: str) -> Path:
    p = folder / "c.yaml"
    p.write_text(text)
    return p


def refused(path: Path) -> str:
    with pytest.raises(ScenarioError) as e:
        load_campaign(path)
    assert "\n" not in str(e.value)
    return str(e.value)


# ---------------------------------------------------------------------------------------------- uav kind
@pytest.mark.parametrize("body, message", [
    ("grid:\n  n_uav: [1, 2]\n", "grid.n_uav: unknown scenario field 'n_uav' (did you mean 'n_uavs'?)"),
    ("grid:\n  wind.probabilty: 0.1\n",
     "grid.wind.probabilty: unknown scenario field 'wind.probabilty' (did you mean 'wind.probability'?)"),
    ("grid:\n  strategy: [A, B, D]\n", "grid.strategy: must be one of A, B, C, got 'D'"),
    ("grid:\n  n_uavs: -2\n", "grid.n_uavs: must be >= 1, got -2"),
    ("grid:\n  n_uavs: [1, two]\n", "grid.n_uavs: expected an integer, got 'two'"),
    ("grid:\n  zone_planning: [true, 0]\n", "grid.zone_planning: expected true or false, got 0"),
    ("grid:\n  wind: {probabilty: 0.1}\n", "grid.wind: wind.probabilty: unknown field (expected one of"),
    ("runs:\n  - {strategy: A}\n  - {wind.probability: 1.5}\n", "runs[1].wind.probability: must be <= 1, got 1.5"),
    ("runs:\n  - {wind.intensities.strong: 1}\n",
     "runs[0].wind.intensities.strong: wind.intensities: speeds must satisfy weak <= moderate <= strong"),
    ("grid:\n  algorithm: [jacobi, newton]\n", "grid.algorithm: must be one of {algorithms}, got 'newton'"),
])
def test_uav_grid_values_are_refused_when_the_campaign_is_loaded(tmp_path, body, message):
    c = write(tmp_path, f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\n{body}")
    assert refused(c) .startswith(f"{c}: {_known(message)}")


def test_a_combination_that_cannot_run_is_named_with_its_values(tmp_path):
    # each value is valid on its own; step 2 is longer than the wind's 1 s decision interval
    c = write(tmp_path, f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\ngrid:\n  strategy: [A, B]\n"
                        "  step: [0.5, 2]\n")
    assert refused(c) == (f"{c}: grid: wind.decision_interval: must be >= step (2), got 1 "
                          f"(the run {{\"step\":2,\"strategy\":\"A\"}} of {SCENARIOS / 'paper_area.yaml'})")


def test_a_fixed_run_option_the_scenario_refuses_names_run(tmp_path):
    c = write(tmp_path, f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\nrun:\n  stop_time: 0.01\n")
    assert refused(c) == (f"{c}: run.stop_time: must be >= step (0.1), got 0.01 "
                          f"(scenario {SCENARIOS / 'paper_area.yaml'})")


def test_every_variant_is_checked(tmp_path):
    zones = (SCENARIOS / "paper_area_zones.yaml").read_text()
    (tmp_path / "free.yaml").write_text((SCENARIOS / "paper_area.yaml").read_text())
    (tmp_path / "zones.yaml").write_text(zones.replace("n_uavs: 4", "n_uavs: 0"))
    c = write(tmp_path, "name: t\ngrid:\n  variant: [free.yaml, zones.yaml]\n  strategy: [A, B]\n")
    assert refused(c) == (f"{c}: grid: n_uavs: must be >= 1, got 0 "
                          '(the run {"strategy":"A","variant":"zones"} of zones.yaml)')
    (tmp_path / "zones.yaml").write_text(zones + "n_uavs: 2\n")
    assert refused(c) == (f"{c}: grid.variant.zones: {tmp_path / 'zones.yaml'}: line {len(zones.splitlines()) + 1}: "
                          "invalid YAML: duplicate key 'n_uavs' (first at line 14)")


def test_the_command_line_prints_one_line_and_runs_nothing(tmp_path, capsys):
    c = write(tmp_path, f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\ngrid:\n  n_uav: [1, 2]\n")
    assert main(["campaign", str(c), "-o", str(tmp_path / "out"), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err == (f"cosim-master: error: {c}: grid.n_uav: unknown scenario field 'n_uav' "
                   "(did you mean 'n_uavs'?)\n")
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------------------------- ssp kind
@pytest.fixture
def chain(tmp_path, chain_fmus):
    return write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)


def _known(message: str) -> str:
    """The message with the registered algorithms (other tests register more) in place of {algorithms}."""
    from master.algorithms import ALGORITHMS
    return message.replace("{algorithms}", ", ".join(ALGORITHMS.names()))


@pytest.mark.parametrize("body, message", [
    ("grid:\n  param:gian.k: [1, 2]\n", "grid.param:gian.k: 'gian.k' does not start with a component name "
                                         "(components: src, gain, integ)"),
    ("grid:\n  param:gain.kk: [1, 2]\n", "grid.param:gain.kk: component 'gain' has no variable 'kk'"),
    ("grid:\n  param:gain.k: [1, abc]\n", "grid.param:gain.k: 'abc' is not a valid Real for gain.k"),
    ("grid:\n  param:src.mode: [1, 2.5]\n", "grid.param:src.mode: expected a value of type Integer for src.mode, got 2.5"),
    ("grid:\n  param:gain.k: [1, true]\n", "grid.param:gain.k: expected a value of type Real for gain.k, got True"),
    ("grid:\n  param:gain.k: [[1, 2]]\n", "grid.param:gain.k: expected a value of type Real for gain.k, got [1, 2]"),
    ("runs:\n  - {param:gain.k: 2}\n  - {param:gain.y: 1}\n",
     "runs[1].param:gain.y: gain.y has causality output and cannot be given a value"),
    ("grid:\n  param:gain.k: [1, 2]\n  step: [0.1, 0]\n", "grid.step: expected a positive number, got 0"),
    ("runs:\n  - {algorithm: newton}\n", "runs[0].algorithm: must be one of {algorithms}, got 'newton'"),
])
def test_ssp_parameters_are_checked_against_the_ssp(tmp_path, chain, body, message):
    c = write(tmp_path, f"name: t\nscenario: chain.ssp\n{body}")
    assert refused(c) == f"{c}: {_known(message)}"


def test_ssp_values_given_as_strings_in_their_type_are_accepted(tmp_path, chain):
    c = write(tmp_path, "name: t\nscenario: chain.ssp\ngrid:\n  param:gain.k: ['2.5', 3]\n"
                        "  param:src.mode: [0, '1']\n")
    assert len(load_campaign(c).runs) == 4


def test_an_ssp_that_cannot_be_read_is_named(tmp_path):
    (tmp_path / "broken.ssp").write_bytes(b"PK\x05\x06" + b"\0" * 18)      # an empty zip
    c = write(tmp_path, "name: t\nscenario: broken.ssp\ngrid:\n  param:gain.k: [1, 2]\n")
    assert refused(c).startswith(f"{c}: scenario: {tmp_path / 'broken.ssp'}: archive has no")


# ---------------------------------------------------------------------------------------------- wrong kind of file
def test_a_scenario_file_given_as_a_campaign_says_so(capsys):
    scenario = SCENARIOS / "paper_area.yaml"
    assert main(["campaign", str(scenario), "--no-progress"]) == 1
    assert capsys.readouterr().err == (
        f"cosim-master: error: {scenario}: (top level): this is a UAV YAML scenario file, not a campaign: name it "
        f"in a campaign's scenario:, or build its SSP with `cosim-master build-scenario {scenario} -o x.ssp`\n")


def test_a_campaign_file_given_to_build_scenario_says_so(tmp_path, capsys):
    campaign = ROOT / "ssp" / "campaigns" / "smoke.yaml"
    assert main(["build-scenario", str(campaign), "-o", str(tmp_path / "x.ssp")]) == 1
    assert capsys.readouterr().err == (
        f"cosim-master: error: {campaign}: this is a campaign file, not a UAV scenario: run it with "
        f"`cosim-master campaign {campaign}`, or build one of the scenario files it names\n")
    assert not (tmp_path / "x.ssp").exists()


def test_the_kind_of_a_file_is_decided_by_its_content_not_its_name(tmp_path):
    scenario = tmp_path / "campaign.yaml"          # a scenario, whatever its name says
    scenario.write_text((SCENARIOS / "paper_area.yaml").read_text())
    assert "this is a UAV YAML scenario file, not a campaign" in refused(scenario)
    campaign = tmp_path / "scenario.yaml"
    campaign.write_text(f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\ngrid:\n  strategy: [A, B]\n")
    assert len(load_campaign(campaign).runs) == 2
    # a campaign with a misspelt field is still a campaign with a misspelt field
    campaign.write_text(f"name: t\nscenario: {SCENARIOS / 'paper_area.yaml'}\ngirds: {{}}\n")
    assert "girds: unknown field (expected one of name" in refused(campaign)
