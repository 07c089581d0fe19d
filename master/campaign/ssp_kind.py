"""The built-in scenario kind ``ssp``: campaigns over SSP archives, SSP folders and .ssd files as they are.

A parameter is ``param:COMPONENT.VARIABLE`` (set through ``master.run(params=...)``) or a run option; the
run seed goes to every parameter named ``seed``.  A run's result is its summary (if a monitor wrote one)
and the last recorded value of every variable.
"""
from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

from ..errors import ScenarioError
from ..scenario_kinds import ParamProblem, PreparedRun, ScenarioKind
from .spec import RUN_OPTIONS, SCENARIO_OPTIONS, canonical_json, file_sha256, scenario_sha256

PARAM_PREFIX = "param:"
#: the Python values a campaign may give a variable of each base type (strings are parsed in the type)
PYTHON_TYPES = {"Real": (int, float), "Integer": (int,), "Boolean": (bool,), "String": (str,)}


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

    def check_params(self, scenario: Path, param_sets: list[tuple[dict, dict]]) -> ParamProblem | None:
        """Each distinct ``param:`` value against the SSP: the variable exists, can be given a value and the
        value is of its type.  Reads the SSD and the FMUs' model descriptions only (no FMU is loaded); the
        run options were checked by the campaign."""
        uses = _first_uses(param_sets)
        if not uses:
            return None
        from ..execution import prepare
        prepared = prepare(scenario)
        try:
            for index, key, value in uses:
                why = _value_error(prepared.plan, key[len(PARAM_PREFIX):], value)
                if why:
                    return ParamProblem(index, key, why)
        finally:
            prepared.source.close()
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


def _first_uses(param_sets: list[tuple[dict, dict]]) -> list[tuple[int, str, object]]:
    """(index of the first set using it, key, value) of every distinct param: value: a large grid repeats
    each value many times, and whether a value fits its variable does not depend on the others."""
    first: dict[tuple[str, str], tuple[int, str, object]] = {}
    for index, (params, _) in enumerate(param_sets):
        for key, value in params.items():
            if key.startswith(PARAM_PREFIX):
                first.setdefault((key, canonical_json(value)), (index, key, value))
    return list(first.values())


def _value_error(plan, qualified: str, value) -> str | None:
    """Why ``value`` cannot be given to the variable ``qualified`` of ``plan`` (None: it can)."""
    from ..plan import add_overrides
    try:
        comp, _, name = plan.split(qualified)
        var = plan.variables[comp][name]
        if not isinstance(value, str) and not _fits(var.type, value):
            return f"expected a value of type {var.fmi_type} for {qualified}, got {value!r}"
        add_overrides(plan, {qualified: value})   # the engine's own checks: the string parses, the variable is settable
    except ScenarioError as exc:
        return exc.reason
    return None


def _fits(base_type: str, value) -> bool:
    if isinstance(value, bool):       # a bool is an int to Python, not to FMI
        return base_type == "Boolean"
    return isinstance(value, PYTHON_TYPES.get(base_type, object))


#: published under the entry point group cosim_master.scenario_kinds (pyproject.toml)
SSP_KIND = SspKind()
