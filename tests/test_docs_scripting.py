"""docs/scripting.md runs as written: its Python blocks, in order, in one namespace, in an empty folder. The
asserts in the walk-through are the checks (closed forms, the first order of Jacobi, the built system equal to
the shipped one); here: that they ran, and that the only file left is the SSP the walk-through writes."""
from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "scripting.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_scripting_walk_through_runs_as_written(tmp_path, monkeypatch, capsys):
    blocks = python_blocks(DOC.read_text(encoding="utf-8"))
    assert len(blocks) >= 6
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "scripting_md"}
    for k, block in enumerate(blocks, start=1):
        try:
            exec(compile(block, f"{DOC.name}, block {k}", "exec"), namespace)
        except Exception as exc:
            raise AssertionError(f"block {k} of {DOC.name} failed: {type(exc).__name__}: {exc}\n{block}") from exc
    out = capsys.readouterr().out
    assert "set A.F: A.F is driven by a connection" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two_masses.ssp"]
