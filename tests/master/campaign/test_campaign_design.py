"""design: one factor at a time and a small factorial around a baseline, each configuration crossed with the
grid; the expansion is checked against a hand-counted list of runs."""
import pytest

from campaign_helpers import write_chain_ssp
from master.campaign.design import design_roles
from master.campaign.spec import load_campaign
from master.errors import ScenarioError


@pytest.fixture
def camp(tmp_path, chain_fmus):
    write_chain_ssp(tmp_path / "chain.ssp", chain_fmus)

    def write(body: str):
        p = tmp_path / "c.yaml"
        p.write_text("name: t\nscenario: chain.ssp\n" + body)
        return p
    return write


DESIGN = """repetitions: 2
grid:
  param:src.mode: [0, 1]
design:
  baseline: {param:gain.k: 1, param:integ.a: 0}
  one_at_a_time:
    param:gain.k: [1, 2, 3]      # 1 is the baseline: not a new configuration
    param:integ.a: [5]
  factorial:
    param:gain.k: [1, 2]
    param:integ.a: [0, 5]
"""


def test_one_at_a_time_and_factorial_expand_to_the_hand_counted_runs(camp):
    c = load_campaign(camp(DESIGN))
    # by hand: configurations (k, a) = baseline (1, 0); one at a time (2, 0), (3, 0), (1, 5); factorial (1, 0),
    # (1, 5), (2, 0) already there, (2, 5) new -> 5 configurations x 2 modes x 2 repetitions = 20 runs
    configs = [(1, 0), (2, 0), (3, 0), (1, 5), (2, 5)]
    expected = [{"param:src.mode": m, "param:gain.k": k, "param:integ.a": a} for k, a in configs for m in (0, 1)]
    assert [r.params for r in c.runs if r.rep == 0] == expected
    assert len(c.runs) == 20 and len({r.run_id for r in c.runs}) == 20
    assert c.param_keys == ["param:src.mode", "param:gain.k", "param:integ.a"]
    assert c.runs[0].overrides == {"src.mode": 0, "gain.k": 1, "integ.a": 0}
    design = c.manifest()["design"]
    roles = {(k, a): design_roles({"param:gain.k": k, "param:integ.a": a}, design) for k, a in configs}
    assert roles == {(1, 0): ["baseline", "factorial"], (2, 0): ["one_at_a_time:param:gain.k", "factorial"],
                     (3, 0): ["one_at_a_time:param:gain.k"], (1, 5): ["one_at_a_time:param:integ.a", "factorial"],
                     (2, 5): ["factorial"]}


def test_design_keeps_the_identity_of_runs_it_shares(camp):
    """Adding a factor value adds runs; the runs already there keep their ids and seeds."""
    a = load_campaign(camp(DESIGN))
    b = load_campaign(camp(DESIGN.replace("param:integ.a: [5]", "param:integ.a: [5, 7]")))
    ids = {r.run_id: r.seed for r in b.runs}
    assert len(b.runs) == 24 and all(ids[r.run_id] == r.seed for r in a.runs)


@pytest.mark.parametrize("body, message", [
    ("design:\n  one_at_a_time: {param:gain.k: [2]}\n", "design.baseline: expected a mapping"),
    ("design:\n  baseline: {param:gain.k: 1}\n  one_at_a_time: {param:integ.a: [2]}\n",
     "design.one_at_a_time.param:integ.a: has no baseline value"),
    ("grid:\n  param:gain.k: [1, 2]\ndesign:\n  baseline: {param:gain.k: 1}\n  factorial: {param:gain.k: [3]}\n",
     "design.baseline.param:gain.k: is a grid axis already"),
    ("design:\n  baseline: {param:gain.k: 1}\n", "design: nothing to vary"),
    ("design:\n  baseline: {param:gain.k: 1}\n  one_at_a_time: {param:gain.k: [2, 2]}\n",
     "design.one_at_a_time.param:gain.k: duplicate value 2"),
    ("design:\n  baseline: {param:gain.kk: 1}\n  one_at_a_time: {param:gain.kk: [2]}\n",
     "component 'gain' has no variable 'kk'"),
    ("design:\n  baseline: {param:gain.k: 1}\n  ofat: {param:gain.k: [2]}\n", "design.ofat: unknown field"),
])
def test_bad_designs_are_refused_in_one_line(camp, body, message):
    with pytest.raises(ScenarioError) as exc:
        load_campaign(camp(body))
    assert message in str(exc.value) and "\n" not in str(exc.value)
