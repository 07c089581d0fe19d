"""master.yamlio: a mapping holding the same key twice is an error (libyaml and pure-Python paths alike),
and the files the project reads say which file, line and key."""
from pathlib import Path

import pytest
import yaml

from master import yamlio
from master.campaign.spec import load_campaign
from master.errors import ScenarioError
from uavstudy.scenario import load_scenario_yaml

ROOT = Path(__file__).resolve().parents[2]
LOADERS = [yamlio.PySafeLoader] + ([yamlio.CSafeLoader] if hasattr(yamlio, "CSafeLoader") else [])


@pytest.mark.parametrize("loader", LOADERS, ids=lambda c: c.__name__)
@pytest.mark.parametrize("text, key, line, first", [
    ("a: 1\nb: 2\na: 3\n", "a", 3, 1),
    ("wind:\n  probability: 0.1\n  probability: 0.2\n", "probability", 3, 2),     # nested mapping
    ("- {x: 1, x: 2}\n", "x", 1, 1),                                              # flow mapping, one line
    ("1: a\n1.0: b\n", 1.0, 2, 1),                                               # the same key spelt twice
])
def test_duplicate_keys_are_refused_with_line_and_key(loader, text, key, line, first):
    with pytest.raises(yaml.YAMLError) as e:
        yaml.load(text, Loader=loader)
    assert e.value.problem == f"duplicate key {key!r} (first at line {first})"
    assert e.value.problem_mark.line + 1 == line


@pytest.mark.parametrize("loader", LOADERS, ids=lambda c: c.__name__)
def test_loading_is_otherwise_safe_load(loader):
    text = "base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  y: 3\nlist: [1, 2.5, true, null]\n"
    assert yaml.load(text, Loader=loader) == yaml.safe_load(text) == \
        {"base": {"x": 1, "y": 2}, "other": {"x": 1, "y": 3}, "list": [1, 2.5, True, None]}
    with pytest.raises(yaml.YAMLError):
        yaml.load("!!python/object:os.system {}\n", Loader=loader)


def test_load_uses_libyaml_when_available():
    if hasattr(yaml, "CSafeLoader"):
        assert yamlio._LOADER is yamlio.CSafeLoader


def test_campaign_file_with_a_duplicate_key(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: t\nscenario: s.ssp\ngrid:\n  param:a.x: [1]\n  param:a.x: [2]\n")
    with pytest.raises(ScenarioError) as e:
        load_campaign(p)
    assert str(e.value) == f"{p}: line 5: invalid YAML: duplicate key 'param:a.x' (first at line 4)"


def test_scenario_file_with_a_duplicate_key(tmp_path):
    text = (ROOT / "ssp" / "scenarios" / "paper_area.yaml").read_text()
    p = tmp_path / "s.yaml"
    p.write_text(text + "n_uavs: 3\n")
    first = next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith("n_uavs:"))
    with pytest.raises(ScenarioError) as e:
        load_scenario_yaml(p)
    assert str(e.value) == (f"{p}: line {len(text.splitlines()) + 1}: invalid YAML: duplicate key 'n_uavs' "
                            f"(first at line {first})")


@pytest.mark.parametrize("loader", ["fast", "pure"])
def test_exponent_without_dot_reads_as_a_number(loader):
    """YAML 1.1 reads `5e-05` as a string (its float rule wants a dot); a step written so by hand must be a number,
    as YAML 1.2 reads it, while words that only look similar stay strings."""
    text = "a: 5e-05\nb: 1e3\nc: -2E+4\nd: e5\ne: 1e\nf: 12\ng: '5e-05'\n"
    data = yamlio.load(text) if loader == "fast" else yaml.load(text, Loader=yamlio.PySafeLoader)
    assert data == {"a": 5e-05, "b": 1000.0, "c": -20000.0, "d": "e5", "e": "1e", "f": 12, "g": "5e-05"}
    assert type(data["b"]) is float and type(data["f"]) is int
    assert yaml.safe_load("a: 5e-05") == {"a": "5e-05"}   # PyYAML's own loader is left as it was
