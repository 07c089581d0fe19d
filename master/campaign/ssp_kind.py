"""The built-in scenario kind ``ssp``: campaigns over SSP archives, SSP folders and .ssd files as they are.

A parameter is ``param:COMPONENT.VARIABLE`` (set through ``master.run(params=...)``) or a run option; the
run seed goes to every parameter named ``seed``.  A run's result is its summary (if a monitor wrote one)
and the last recorded value of every variable.
"""
from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

from ..scenario_kinds import SCENARIO_KINDS, PreparedRun, ScenarioKind
from .spec import RUN_OPTIONS, SCENARIO_OPTIONS, file_sha256, scenario_sha256

PARAM_PREFIX = "param:"


class SspKind(ScenarioKind):
    name = "ssp"
    label = "SSP"

    def claims(self, path: Path) -> bool:
        return path.is_dir() or path.suffix.lower() in (".ssp", ".ssd") or zipfile.is_zipfile(path)

    def param_key_error(self, key: str) -> str | None:
        if key.startswith(PARAM_PREFIX):
            q = key[len(PARAM_PREFIX):]
            if "." not in q or q.startswith(".") or q.endswith("."):
                return "expected param:COMPONENT.VARIABLE"
        elif key not in RUN_OPTIONS and key != "variant":
            return f"for an SSP scenario a parameter is param:COMPONENT.VARIABLE or a run option " \
                   f"({', '.join(RUN_OPTIONS)})"
        return None

    def overrides(self, params: dict, options: dict) -> dict:
        return {k[len(PARAM_PREFIX):]: v for k, v in params.items()}

    def input_fmus(self, scenario: Path) -> dict:
        """SHA-256 of every FMU the scenario holds (archive members, or files under a folder)."""
        out = {}
        if scenario.is_file() and zipfile.is_zipfile(scenario):
            with zipfile.ZipFile(scenario) as zf:
                for name in sorted(zf.namelist()):
                    if name.lower().endswith(".fmu"):
                        h = hashlib.sha256()
                        with zf.open(name) as fh:
                            for chunk in iter(lambda: fh.read(1 << 20), b""):
                                h.update(chunk)
                        out[name] = h.hexdigest()
            return out
        folder = scenario if scenario.is_dir() else scenario.parent
        for p in sorted(folder.rglob("*.fmu")):
            out[str(p.relative_to(folder))] = file_sha256(p)
        return out

    def prepare_run(self, task: dict, out: Path, used: dict) -> PreparedRun:
        scenario = Path(task["scenario"])
        used["scenario_sha256"] = scenario_sha256(scenario)
        opts = task["options"]
        return PreparedRun(scenario, dict(task["overrides"]), int(task["seed"]),
                           {k: opts[k] for k in SCENARIO_OPTIONS if k in opts})


SCENARIO_KINDS.register(SspKind.name, SspKind())
