"""The package list in pyproject.toml is explicit (two packages live under fmu_sources/): a package missing from
it works in the editable install the README uses but is left out of a wheel, where the first import fails
(master.observers and master.sinks were missing once)."""
from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _declared():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    return set(cfg["packages"]), cfg.get("package-dir", {})


def _package_folder(name: str, package_dir: dict) -> Path:
    head, *rest = name.split(".")
    return ROOT.joinpath(package_dir.get(head, head), *rest)


def test_every_package_folder_is_declared():
    declared, package_dir = _declared()
    tops = {n.split(".")[0] for n in declared}
    found = set()
    for top in tops:
        base = _package_folder(top, package_dir)
        for init in base.rglob("__init__.py"):
            rel = init.parent.relative_to(base).parts
            if "__pycache__" not in rel:
                found.add(".".join((top, *rel)))
    assert found - declared == set(), "packages missing from pyproject.toml [tool.setuptools] packages"


def test_every_declared_package_exists():
    declared, package_dir = _declared()
    missing = {n for n in declared if not (_package_folder(n, package_dir) / "__init__.py").is_file()}
    assert missing == set()


def test_no_test_folder_shadows_a_package_of_the_project():
    """tests/ is on sys.path (the root conftest): a folder there named like a package the project installs would
    be imported as an empty namespace package in its place (uavsim.__file__ None) wherever that package is not on
    sys.path itself, as the editable install's own finder comes after sys.path."""
    import importlib

    for name in ("master", "uavstudy", "uavsim", "sitlsim"):
        module = importlib.import_module(name)
        assert module.__file__ is not None and module.__file__.endswith("__init__.py"), (name, module.__path__)
