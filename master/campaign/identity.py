"""What identifies a campaign's run and what its results depend on: canonical JSON, run ids, seeds and the
fingerprints of a run's inputs.

Everything that identifies a run is derived from canonical JSON (sorted keys, integral floats written as
integers) so that it does not depend on the order of the grid keys or on how a number was spelled:

* ``run_id`` = first 12 hex digits of SHA-256 over ``{"params": ..., "rep": r}``;
* ``seed``   = first 8 hex digits (31 bits) of SHA-256 over ``{"campaign_seed": s, "params": ..., "rep": r}``.

Adding a value to a grid axis therefore adds runs without touching the identity or the seed of the runs that
were already there.  The *inputs* of a run (hashes of its scenario file and FMUs, the run options that change
its results, its seed, the code it executes) are fingerprinted separately: a finished run whose fingerprint no
longer matches is stale and runs again.
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

from ..scenario_kinds import SCENARIO_KINDS
from ..ssp.archive import file_sha256

__all__ = ["canonical", "canonical_json", "digest", "run_id_for", "seed_for", "SEED_MASK", "file_sha256",
           "scenario_sha256", "code_sha256", "REPORT_ONLY"]

SEED_MASK = 0x7FFFFFFF          # FMI Integer parameters are 32-bit signed


def canonical(v: Any) -> Any:
    """Canonical form of a parameter value: integral floats become ints, tuples lists, dict keys sorted."""
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if isinstance(v, int):
        return int(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            # YAML reads a number beyond a double's range (1.0e+400) as infinity: say so, the file shows no inf
            raise ValueError(f"non-finite number {v!r} (.inf, .nan, or a number beyond a 64-bit float's range "
                             "of ±1.8e308)")
        return int(v) if v.is_integer() and abs(v) < 2 ** 53 else float(v)
    if isinstance(v, (list, tuple)):
        return [canonical(x) for x in v]
    if isinstance(v, dict):
        return {str(k): canonical(x) for k, x in sorted(v.items(), key=lambda kv: str(kv[0]))}
    return str(v)


def canonical_json(obj: Any) -> str:
    return _json_of_canonical(canonical(obj))


def _json_of_canonical(c: Any) -> str:
    return json.dumps(c, sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def digest(obj: Any) -> str:
    """SHA-256 (hex) of the canonical JSON of ``obj``."""
    return _digest_of_canonical(canonical(obj))


def _digest_of_canonical(c: Any) -> str:
    """``digest`` of a value already in canonical form (``canonical(c) == c``, as every value ``canonical`` returns
    is): the same, without walking it again."""
    return hashlib.sha256(_json_of_canonical(c).encode("ascii")).hexdigest()


def run_id_for(params: dict, rep: int) -> str:
    return run_id_of_canonical(canonical(params), rep)


def run_id_of_canonical(cparams: dict, rep: int) -> str:
    """``run_id_for`` of ``canonical(params)``: a campaign's repetitions of one parameter set canonicalise it once."""
    return _digest_of_canonical({"params": cparams, "rep": int(rep)})[:12]


def seed_for(campaign_seed: int, params: dict, rep: int) -> int:
    return seed_of_canonical(campaign_seed, canonical(params), rep)


def seed_of_canonical(campaign_seed: int, cparams: dict, rep: int) -> int:
    """``seed_for`` of ``canonical(params)``."""
    c = {"campaign_seed": int(campaign_seed), "params": cparams, "rep": int(rep)}
    return int(_digest_of_canonical(c)[:8], 16) & SEED_MASK


def scenario_sha256(path: Path) -> str:
    """Hash of a scenario file, or of an SSP folder without its FMUs (hashed one by one as inputs)."""
    return file_sha256(path) if path.is_file() else _folder_sha256(path)


def _folder_sha256(folder: Path) -> str:
    """Hash of an SSP folder: its SSD and SSV/SSM files (FMUs are hashed one by one)."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix.lower() != ".fmu":
            h.update(str(p.relative_to(folder)).encode() + b"\0" + file_sha256(p).encode())
    return h.hexdigest()


#: modules that only read finished records (the report, the table): editing them changes no run's result
REPORT_ONLY = ("master/campaign/report.py", "master/campaign/stats.py", "master/campaign/table.py",
               "master/campaign/blocked.py",
               "master/cli.py", "master/inspect_scenario.py", "master/study/__init__.py",
               "master/study/compare.py", "master/study/figures.py", "master/study/reference.py",
               "master/study/study.py")
_code_sha: str | None = None


def code_sha256() -> str:
    """Hash of the code a run executes besides its FMUs: the master package and the code roots of every
    scenario kind (a study's package and the models its FMUs are built from; in-process runs may use the
    installed copy), without the report-only modules.  Part of every run's inputs, so a campaign resumed
    after a code change reruns its runs."""
    global _code_sha
    if _code_sha is None:
        kinds = SCENARIO_KINDS.load_all().values()
        master_root = Path(__file__).resolve().parents[1]
        roots = [master_root, *(Path(root).resolve() for k in kinds for root in k.code_roots())]
        report_only = set(REPORT_ONLY).union(*(k.report_only for k in kinds))
        h = hashlib.sha256()
        for root in dict.fromkeys(roots):
            for f in sorted(list(root.rglob("*.py")) + list(root.rglob("*.c"))):
                rel = f"{root.name}/{f.relative_to(root).as_posix()}"
                if rel not in report_only and "__pycache__" not in rel:
                    h.update(rel.encode() + b"\0" + file_sha256(f).encode() + b"\0")
        _code_sha = h.hexdigest()
    return _code_sha
