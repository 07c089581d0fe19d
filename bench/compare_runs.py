"""Are two run folders (or two campaign folders) the same, bit for bit, apart from wall times and paths?

    python bench/compare_runs.py BEFORE AFTER      # prints one line per file and exits 1 on any difference

Used to check that a refactoring leaves results unchanged: run the shipped scenarios (or a campaign) with the
old and the new code into two folders and compare them. Parquet files are compared as tables (values and
column types); CSV files as text; JSON files without the keys that hold times, paths, versions or hashes of
the code.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

VOLATILE = {"wall_time_s", "finished_at", "worker", "scenario", "platform", "python", "package_version",
            "code_sha256", "inputs_sha256", "inputs", "used", "campaign_file", "runs_per_min", "elapsed_s",
            "traceback", "timing", "supervised", "products", "native_loop",   # how the run was executed and filed
            # the FMU and run-archive hashes name the code that ran (any rebuild changes them), not what it computed
            "sha256", "scenario_sha256"}
SKIP_FILES = {"fmu.log", "map.png", "report.md", "progress.json", "invocations.jsonl"}


def _fmu_hashes(key, value) -> bool:
    """A campaign record's ``fmus``: component -> the SHA-256 of its FMU (run.json's entries hold more, and only
    their ``sha256`` is left out)."""
    return key == "fmus" and isinstance(value, dict) and all(isinstance(v, str) for v in value.values())


def _clean(o):
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items() if k not in VOLATILE and not _fmu_hashes(k, v)}
    if isinstance(o, list):
        return [_clean(v) for v in o]
    return o


def _same(a: Path, b: Path) -> str | None:
    if a.suffix == ".parquet":
        import pyarrow.parquet as pq
        ta, tb = pq.read_table(a), pq.read_table(b)
        drop = [c for c in ta.column_names if c in VOLATILE or c.endswith("wall_time_s")]
        ta, tb = ta.drop_columns([c for c in drop if c in ta.column_names]), \
            tb.drop_columns([c for c in drop if c in tb.column_names])
        return None if ta.equals(tb) else f"tables differ ({ta.num_rows} vs {tb.num_rows} rows)"
    if a.suffix == ".json":
        ja, jb = _clean(json.loads(a.read_text())), _clean(json.loads(b.read_text()))
        return None if ja == jb else "JSON differs"
    if a.suffix in (".csv", ".yaml", ".md", ".txt"):
        if a.name in ("results.csv",) and (a.parent / "campaign.json").is_file():
            return None   # the campaign table's CSV twin holds wall times; its Parquet is compared
        return None if a.read_bytes() == b.read_bytes() else "text differs"
    return None if a.read_bytes() == b.read_bytes() else "bytes differ"


def main(argv=None) -> int:
    a_root, b_root = (Path(x) for x in (argv or sys.argv[1:]))
    bad = 0
    files = sorted(p.relative_to(a_root) for p in a_root.rglob("*") if p.is_file() and p.name not in SKIP_FILES
                   and ".tmp" not in p.name)
    for rel in files:
        other = b_root / rel
        why = "missing" if not other.is_file() else _same(a_root / rel, other)
        if why:
            bad += 1
            print(f"DIFF {rel}: {why}")
    print(f"{len(files)} files compared, {bad} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
