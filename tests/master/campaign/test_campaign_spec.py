"""Campaign files: grid expansion, run identities and seeds, validation messages, the shipped campaigns."""
from pathlib import Path

import pytest

from campaign_helpers import write_chain_ssp
from master.campaign.spec import canonical_json, load_campaign, run_id_for, seed_for
from master.errors import ScenarioError

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def camp(tmp_path, chain_fmus):
    """Writes a campaign over chain.ssp (src.mode, src.fail_time, gain.k, integ.a, ...: its param: names
    are checked against the SSP) with the given body."""
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)

    def write(body: str):
        p = tmp_path / "c.yaml"
        p.write_text("name: t\nscenario: chain.ssp\n" + body)
        return p
    return write


def test_grid_is_the_cartesian_product_in_file_order(camp):
    c = load_campaign(camp("repetitions: 2\ngrid:\n  param:gain.k: [1, 2]\n  step: [0.1, 0.2, 0.5]\n"))
    assert len(c.runs) == 12 and c.param_keys == ["param:gain.k", "step"]
    assert [(r.params["param:gain.k"], r.params["step"], r.rep) for r in c.runs[:4]] == \
        [(1, 0.1, 0), (1, 0.1, 1), (1, 0.2, 0), (1, 0.2, 1)]
    r = c.runs[0]
    assert r.overrides == {"gain.k": 1} and r.options["step"] == 0.1
    assert len({r.run_id for r in c.runs}) == 12 and len({r.seed for r in c.runs}) == 12


def test_adding_grid_values_keeps_ids_and_seeds(camp):
    a = load_campaign(camp("seed: 5\nrepetitions: 3\ngrid:\n  param:gain.k: [1, 2]\n  param:src.mode: [0]\n"))
    b = load_campaign(camp("seed: 5\nrepetitions: 4\ngrid:\n  param:src.mode: [0, 1]\n"
                           "  param:gain.k: [3, 1.0, 2]\n"))
    ids_b = {r.run_id: r.seed for r in b.runs}
    for r in a.runs:      # same canonical parameters (1 == 1.0, key order irrelevant) -> same id and seed
        assert ids_b[r.run_id] == r.seed
    c = load_campaign(camp("seed: 6\nrepetitions: 3\ngrid:\n  param:gain.k: [1, 2]\n  param:src.mode: [0]\n"))
    assert [r.run_id for r in c.runs] == [r.run_id for r in a.runs]       # the id does not depend on the seed
    assert all(x.seed != y.seed for x, y in zip(a.runs, c.runs))         # the seed does


def test_identity_functions_are_canonical():
    assert canonical_json({"b": 1.0, "a": [2.50, True]}) == '{"a":[2.5,true],"b":1}'
    assert run_id_for({"x": 1.0}, 0) == run_id_for({"x": 1}, 0) != run_id_for({"x": 1}, 1)
    s = seed_for(0, {"x": 1}, 0)
    assert 0 <= s < 2 ** 31 and s == seed_for(0, {"x": 1.0}, 0)


def test_explicit_runs_and_duplicates(camp):
    c = load_campaign(camp("grid:\n  param:gain.k: [1, 2]\n"
                           "runs:\n  - {param:gain.k: 3, algorithm: gauss-seidel}\n"))
    assert [r.params for r in c.runs] == [{"param:gain.k": 1}, {"param:gain.k": 2},
                                          {"param:gain.k": 3, "algorithm": "gauss-seidel"}]
    assert c.runs[2].options["algorithm"] == "gauss-seidel" and c.param_keys == ["param:gain.k", "algorithm"]
    with pytest.raises(ScenarioError, match="appears twice"):
        load_campaign(camp("grid:\n  param:gain.k: [1, 2]\nruns:\n  - {param:gain.k: 2.0}\n"))


@pytest.mark.parametrize("body, message", [
    ("grid:\n  param:a: [1]\n", "grid.param:a: expected param:COMPONENT.VARIABLE"),
    ("grid:\n  strategy: [A]\n", "grid.strategy: for an SSP scenario a parameter is param:COMPONENT.VARIABLE"),
    ("grid:\n  seed: [1, 2]\n", "grid.seed: is derived by the campaign"),
    ("grid:\n  param:gain.k: []\n", "grid.param:gain.k: empty list of values"),
    ("grid:\n  param:gain.k: [1, 1.0]\n", "duplicate value 1"),
    ("run:\n  step: -1\n", "run.step: expected a positive number, got -1"),
    ("run:\n  stepsize: 1\n", "run.stepsize: unknown run option"),
    ("keep: some\n", "keep: must be one of summary, all"),
    ("repetitions: 0\n", "repetitions: expected an integer >= 1"),
    ("grids: {}\n", "grids: unknown field"),
    ("paired: [param:gain.k]\n", "paired: 'param:gain.k' is not a parameter of this campaign"),
    ("grid:\n  param:gain.k: [1]\npaired: {a: 1}\n", "paired: expected a parameter name or a list of them"),
])
def test_bad_campaign_files_give_one_line_errors(tmp_path, camp, body, message):
    with pytest.raises(ScenarioError) as e:
        load_campaign(camp(body))
    assert message in str(e.value) and "\n" not in str(e.value) and str(tmp_path / "c.yaml") in str(e.value)


def test_paired_parameters_are_left_out_of_the_seed(camp):
    # paired: [param:src.mode] -> runs differing only in src.mode share their seed (common random numbers);
    # their ids differ
    body = "seed: 3\nrepetitions: 2\ngrid:\n  param:src.mode: [1, 2]\n  param:integ.a: [0.1, 0.2]\n"
    plain = load_campaign(camp(body))
    paired = load_campaign(camp(body + "paired: param:src.mode\n"))
    assert paired.paired == ["param:src.mode"] and paired.manifest()["paired"] == ["param:src.mode"]
    assert [r.run_id for r in paired.runs] == [r.run_id for r in plain.runs]
    by = {(r.params["param:src.mode"], r.params["param:integ.a"], r.rep): r.seed for r in paired.runs}
    for (k, w, rep), s in by.items():
        assert s == by[(3 - k, w, rep)] == seed_for(3, {"param:integ.a": w}, rep)
    assert len(set(by.values())) == 4 and len({r.seed for r in plain.runs}) == 8


def test_missing_scenario(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: t\nscenario: nowhere.ssp\n")
    with pytest.raises(ScenarioError, match="scenario: scenario not found"):
        load_campaign(p)


def test_shipped_paper_campaign_is_the_papers_grid():
    c = load_campaign(ROOT / "ssp" / "campaigns" / "paper.yaml")
    # the paper's 112-run grid per repetition; 24 repetitions = 24 independent layouts (docs/paper_reproduction.md,
    # "How many layouts"), i.e. the paper's 336 runs eight times over
    assert c.kind == "uav" and c.repetitions == 24 and len(c.runs) == 112 * 24
    assert sorted({r.params["strategy"] for r in c.runs}) == ["A", "B"]
    assert sorted({r.params["n_uavs"] for r in c.runs}) == [1, 2, 3, 4]
    assert sorted({r.params["variant"] for r in c.runs}) == ["free", "zones"]
    assert sorted({r.params["wind.probability"] for r in c.runs}) == [0, 0.025, 0.05, 0.075, 0.1, 0.125, 0.15]
    # paired on the strategy: A and B of the same grid point and repetition fly the same wind
    assert c.paired == ["strategy"]
    assert len({r.run_id for r in c.runs}) == 112 * 24 and len({r.seed for r in c.runs}) == 56 * 24
    seeds = {(r.params["strategy"], r.params["n_uavs"], r.params["variant"], r.params["wind.probability"], r.rep):
             r.seed for r in c.runs}
    assert all(seeds[("A", *k[1:])] == seeds[("B", *k[1:])] for k in seeds)
    r = c.runs[0]
    assert r.overrides["stop_time"] == 1500 and r.overrides["step"] == c.options["step"] <= 0.5
    assert set(r.inputs["fmus"]) == {"UavBattery.fmu", "UavDynamics.fmu", "UavStrategy.fmu", "UavWind.fmu",
                                       "UavChannel.fmu"}        # strategy C's channel, which a grid may choose
    s = load_campaign(ROOT / "ssp" / "campaigns" / "smoke.yaml")
    assert s.kind == "uav" and 1 <= len(s.runs) <= 8
