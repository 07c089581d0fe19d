"""What the README's commands write into the checkout is git-ignored (or a shipped file they rebuild), so that a
new user's first hour leaves ``git status`` clean."""
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _git(*args):
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=60)


def _written_by_readme() -> set[str]:
    """Paths (relative to the checkout) that the README's shell commands write, run from the checkout."""
    text = (ROOT / "README.md").read_text()
    paths = set()
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            for command in re.split(r"&&|;", line.split("#")[0]):
                try:
                    words = shlex.split(command)
                except ValueError:
                    continue
                if "cosim-master" not in " ".join(words[:1]) and not words[:1] == ["cosim-master"]:
                    if words[:2] == ["python", "ssp/build_all.py"]:
                        sys.path.insert(0, str(ROOT / "ssp"))
                        try:
                            from build_all import AS_IS, variants
                        finally:
                            sys.path.pop(0)
                        paths |= {f"ssp/paper_{a}_{n}uav_{s}.ssp" for a, n, s in variants("--all" in words)}
                        paths |= {f"ssp/{name}.ssp" for name in AS_IS}
                    continue
                for flag in ("-o", "--output"):
                    if flag in words and words.index(flag) + 1 < len(words):
                        paths.add(words[words.index(flag) + 1])
                if len(words) > 2 and "-o" not in words and "--output" not in words:
                    if words[1] in ("run", "campaign"):        # the default folder: results/<scenario name>
                        paths.add(f"results/{Path(words[2]).stem}/run.json")
                    if words[1] == "report":
                        paths.add(f"{words[2]}/report.md")
    paths = {p for p in paths if p.isascii() and not p.isupper() and "DIR" not in p}
    paths |= {"out/results.csv", "my.ssp.tmp"}       # the Python API's output="out"; the writer's temporary
    return paths


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout")
def test_what_the_readme_writes_is_ignored():
    paths = _written_by_readme()
    assert "my.ssp" in paths and "ssp/paper_free_2uav_A.ssp" in paths and "results/smoke/run.json" in paths
    tracked = set(_git("ls-files", *paths).stdout.split())
    ignored = set(_git("check-ignore", "--no-index", *paths).stdout.split())
    assert paths - tracked - ignored == set()
