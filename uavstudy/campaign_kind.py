"""The ``uav`` scenario kind: campaigns (and ``cosim-master build-scenario``) over UAV study YAML scenarios.

Published to the engine through the ``cosim_master.scenario_kinds`` entry point.  A campaign parameter is
a scenario field path (``strategy``, ``n_uavs``, ``wind.probability``, ...); each run writes its own
``scenario.yaml`` (base scenario + parameters + run seed) and builds its SSP from it, so the seed reaches
the wind FMU through the scenario and the step, stop time and algorithm through the SSD.
"""
from __future__ import annotations

import copy
import difflib
import functools
import hashlib
import json
import pickle
from pathlib import Path

import yaml

from master import yamlio
from master.campaign.execute import kept_after_run
from master.campaign.spec import SCENARIO_OPTIONS, file_sha256, is_campaign_document
from master.errors import ScenarioError
from master.scenario_kinds import ParamProblem, PreparedRun, ScenarioKind

from .names import TOTAL_ROW, UAV_COLUMN

SUFFIXES = (".yaml", ".yml")


def _set_path(data: dict, key: str, value, shown: str):
    """Set the scenario field ``a.b.c`` (creating the mappings on the way)."""
    parts = key.split(".")
    d = data
    for i, p in enumerate(parts[:-1]):
        nxt = d.get(p)
        if nxt is None:
            nxt = d[p] = {}
        if not isinstance(nxt, dict):
            raise ScenarioError(f"cannot set {key!r}: {'.'.join(parts[:i + 1])} is not a mapping", file=shown,
                                element=key)
        d = nxt
    d[parts[-1]] = value


@functools.cache
def _field_paths() -> dict[str, None]:
    """Every scenario field as a dotted path (``n_uavs``, ``wind``, ``wind.intensities.strong``), in file
    order: the keys of the model's own YAML form of a scenario."""
    from .scenario import STRATEGIES, UavScenario, scenario_to_dict
    blank = UavScenario(name="", base=(0.0, 0.0, 0.0), n_uavs=1, strategy=STRATEGIES[0], targets=[])
    paths: dict[str, None] = {}

    def walk(d: dict, prefix: str):
        for k, v in d.items():
            paths[prefix + k] = None
            if isinstance(v, dict):
                walk(v, f"{prefix}{k}.")
    walk(scenario_to_dict(blank), "")
    return paths


def _uses_sitl(scenario: Path) -> bool:
    try:
        data = yamlio.load(Path(scenario).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return False
    veh = data.get("vehicle") if isinstance(data, dict) else None
    return veh == "sitl" or (isinstance(veh, list) and "sitl" in veh)


def _unknown_field(key: str) -> str:
    close = difflib.get_close_matches(key, list(_field_paths()), n=1)
    hint = f"did you mean {close[0]!r}?" if close else f"fields: {', '.join(_field_paths())}"
    return f"unknown scenario field {key!r} ({hint})"


def _problem(index: int, exc: ScenarioError, overrides: dict) -> ParamProblem:
    """The scenario model's error as a problem of the parameter (or run option) it comes from."""
    key = next((k for k in sorted(overrides, key=len, reverse=True)
                if _within(exc.element or "", k) or _within(k, exc.element or "")), None)
    return ParamProblem(index, key, exc.reason if exc.element in (key, None) else f"{exc.element}: {exc.reason}")


def _within(path: str, prefix: str) -> bool:
    """Is the field ``path`` the field ``prefix`` or inside it (``wind.probability`` in ``wind``)?"""
    return path == prefix or path.startswith((prefix + ".", prefix + "["))


def _read_scenario_data(path: Path) -> dict:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read the scenario: {exc}", file=str(path)) from None
    data = yamlio.load_text(text, path)
    if not isinstance(data, dict):
        raise ScenarioError("expected a mapping of scenario fields", file=str(path))
    return data


def _refuse_campaign_document(source: Path):
    """A campaign file given to build-scenario: say what it is, rather than list the scenario fields it lacks
    (an unreadable file is left to the scenario loader's own message)."""
    try:
        data = yamlio.load_text(source.read_text(encoding="utf-8"), source)
    except (OSError, UnicodeDecodeError, ScenarioError):
        return
    if is_campaign_document(data):
        raise ScenarioError(f"this is a campaign file, not a UAV scenario: run it with `cosim-master campaign "
                            f"{source}`, or build one of the scenario files it names", file=str(source))


def layout_seed(campaign_seed: int, rep: int) -> int:
    """The random layout of repetition ``rep``: a function of the campaign seed and the repetition only, so every
    cell of the grid (strategy, fleet size, wind, area variant) flies the same area in the same repetition."""
    digest = hashlib.sha256(json.dumps({"campaign_seed": int(campaign_seed), "layout_rep": int(rep)},
                                       sort_keys=True).encode()).hexdigest()
    return int(digest[:8], 16) & 0x7FFFFFFF


#: a worker's parsed base scenarios by the SHA-256 of their bytes, pickled: a campaign has one or two base files
#: and hundreds of runs, and parsing the YAML (or deep-copying the parsed mapping) cost more than unpickling it
_BASES: dict[str, bytes] = {}
_MAX_BASES = 16


def _base_data(sha: str, raw: bytes):
    """A fresh copy of the parsed base scenario (each run modifies its own)."""
    pickled = _BASES.get(sha)
    if pickled is None:
        data = yamlio.load(raw.decode("utf-8"))
        if len(_BASES) >= _MAX_BASES:
            _BASES.clear()
        _BASES[sha] = pickled = pickle.dumps(data, protocol=pickle.HIGHEST_PROTOCOL)
    return pickle.loads(pickled)


#: (top-level key, its value pickled) -> that item's lines of a run's scenario.yaml: the runs of a campaign repeat
#: most fields (the targets, the wind's intensities, ...), and turning them into YAML cost more than the rest
_YAML_ITEMS: dict[tuple, str] = {}
_MAX_YAML_ITEMS = 1024
_LAST = "~last"                 # an item put after one dumped alone, to keep the mapping in block style
_LAST_TEXT = _LAST + ":\n- []\n"


def _dump(data) -> str:
    return yamlio.dump(data, sort_keys=False, default_flow_style=None)


def dump_scenario(data: dict) -> str:
    """``yamlio.dump(data, sort_keys=False, default_flow_style=None)``, item by item.  A mapping with a collection
    among its values is written in block style, its items one after the other from the first column, each the
    same text whatever the others are -- unless an object appears under two of them (YAML writes it once, with an
    anchor): that, and a mapping of scalars only (written in flow style), is dumped whole."""
    if (not any(isinstance(v, (dict, list, tuple, set)) for v in data.values()) or _LAST in data
            or not all(type(k) is str for k in data) or _shares_objects(data)):
        return _dump(data)
    parts = []
    for k, v in data.items():
        key = (k, pickle.dumps(v, protocol=pickle.HIGHEST_PROTOCOL))
        text = _YAML_ITEMS.get(key)
        if text is None:
            text = _dump({k: v, _LAST: [[]]})
            if not text.endswith(_LAST_TEXT):       # cannot happen with PyYAML's emitter: no shortcut then
                return _dump(data)
            if len(_YAML_ITEMS) >= _MAX_YAML_ITEMS:
                _YAML_ITEMS.clear()
            text = _YAML_ITEMS[key] = text[:-len(_LAST_TEXT)]
        parts.append(text)
    return "".join(parts)


def _shares_objects(data: dict) -> bool:
    """Is an object that YAML would write once and refer to again (anything but None, the empty tuple, strings,
    bytes and numbers: ``SafeRepresenter.ignore_aliases``) reachable from two top-level items?"""
    owner: dict[int, str] = {}
    for k, v in data.items():
        stack = [v]
        while stack:
            obj = stack.pop()
            if obj is None or isinstance(obj, (str, bytes, bool, int, float)) or (type(obj) is tuple and not obj):
                continue
            seen = owner.get(id(obj))
            if seen is not None:
                if seen != k:
                    return True
                continue            # met again within this item: walked already (and dumped with it)
            owner[id(obj)] = k
            if isinstance(obj, dict):
                stack += obj.keys()
                stack += obj.values()
            elif isinstance(obj, (list, tuple, set, frozenset)):
                stack += obj
    return False


class UavKind(ScenarioKind):
    name = "uav"
    label = "UAV YAML"
    member_column = UAV_COLUMN
    records_final_values = False     # the monitor's summary is the result (final values would be per UAV)
    #: every module of the report package (a new one is covered without being listed)
    report_only = tuple(f"uavstudy/report/{f.name}" for f in sorted((Path(__file__).parent / "report").glob("*.py")))
    summary_files = ("photos.csv", "scenario.yaml")
    # what a run imports before its FMUs load (prepare_run: the build and its scenario; the monitor); ~1 s of a
    # worker's first run at load 5, paid once in the fork server instead (the FMU shells import pythonfmu)
    worker_modules = ("uavstudy.build", "uavstudy.scenario", "uavstudy.monitor", "pythonfmu")

    def claims(self, path: Path) -> bool:
        return path.suffix.lower() in SUFFIXES

    def build(self, source: Path, output: Path) -> Path:
        from .build import build_scenario
        _refuse_campaign_document(source)
        return build_scenario(source, output)

    def is_scenario_document(self, data) -> bool:
        """Most of its top-level keys are scenario fields (a campaign shares only ``name`` and ``seed``)."""
        fields = _field_paths()
        return isinstance(data, dict) and sum(k in fields for k in data) > len(data) / 2

    def param_key_error(self, key: str) -> str | None:
        if key.startswith("param:"):
            return ("param:COMPONENT.VARIABLE keys are for SSP scenarios; a UAV YAML scenario takes its own "
                    "field names (strategy, n_uavs, wind.probability, ...)")
        return None     # any scenario field may vary; check_params checks the names and the values

    def check_params(self, scenario: Path, param_sets: list[tuple[dict, dict]]) -> ParamProblem | None:
        """Every parameter set applied to the base YAML as its runs will be and validated by the scenario model
        itself (``scenario_from_dict``: types, ranges and the cross-field rules), after the names: a misspelt
        field is named with the closest real one.  About 0.25 ms per set (paper.yaml's 112: 0.03 s)."""
        from .scenario import scenario_from_dict
        for index, (params, _) in enumerate(param_sets):
            for key in params:
                if key not in _field_paths():
                    return ParamProblem(index, key, _unknown_field(key))
        base = _read_scenario_data(scenario)
        for index, (params, options) in enumerate(param_sets):
            overrides = self.overrides(params, options)
            data = copy.deepcopy(base)
            try:
                for k, v in overrides.items():
                    _set_path(data, k, v, str(scenario))
                data["seed"] = 0        # a run's seed replaces the base's, and any seed is valid
                scenario_from_dict(data, scenario)
            except ScenarioError as exc:
                return _problem(index, exc, overrides)
        return None

    def overrides(self, params: dict, options: dict) -> dict:
        # the step, stop time and algorithm are scenario fields: the SSP built from the scenario carries them
        return {**params, **{k: options[k] for k in SCENARIO_OPTIONS if k in options}}

    def input_fmus(self, scenario: Path) -> dict:
        """The study's FMUs (every UAV scenario runs the same four, strategy C also the channel, which a grid may
        choose), and the SITL vehicle's when the base scenario flies SITL (docs/sitl.md)."""
        from .build import CHANNEL_FMU, FMU_FILES, SITL_FMU, default_fmu_dir
        d = default_fmu_dir()
        files = sorted(FMU_FILES.values()) + [CHANNEL_FMU] + ([SITL_FMU] if _uses_sitl(scenario) else [])
        return {f: file_sha256(d / f) if (d / f).is_file() else None for f in files}

    def code_roots(self) -> list[Path]:
        import sitlsim
        import uavsim
        return [Path(__file__).resolve().parent, Path(uavsim.__file__).resolve().parent,
                Path(sitlsim.__file__).resolve().parent]

    def prepare_run(self, task: dict, out: Path, used: dict) -> PreparedRun:
        """Base YAML + overrides + seed -> runs/<id>/scenario.yaml -> scenario.ssp."""
        from .build import build_ssp
        from .scenario import scenario_from_dict
        src = Path(task["scenario"])
        try:
            raw = src.read_bytes()
            used["scenario_sha256"] = sha = hashlib.sha256(raw).hexdigest()
            data = _base_data(sha, raw)
        except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
            raise ScenarioError(f"cannot read the scenario: {exc}", file=str(src)) from None
        if not isinstance(data, dict):
            raise ScenarioError("expected a mapping of scenario fields", file=str(src))
        for k, v in task["overrides"].items():
            _set_path(data, k, v, str(src))
        data["seed"] = int(task["seed"])
        if data.get("layout") == "random" and "layout_seed" not in task["overrides"]:
            data["layout_seed"] = layout_seed(task["campaign_seed"], task["rep"])
        # a campaign run ends when its fleet has landed (the summary is the same; the idle rest is skipped)
        data.setdefault("end_when_all_landed", True)
        head = (f"# campaign {task['campaign']}, run {task['run_id']} (rep {task['rep']}, seed {task['seed']})\n"
                f"# base scenario: {task['inputs']['scenario']}; "
                f"parameters: {json.dumps(task['params'], sort_keys=True)}\n")
        yml = out / "scenario.yaml"
        yml.write_text(head + dump_scenario(data), encoding="utf-8")
        scn = scenario_from_dict(data, yml)       # what was just written, without parsing it again
        # the scenario's seed field (wind) is the run seed already; the archive is written to the run folder only
        # if the folder keeps it (else the run reads it from memory)
        ssp = out / "scenario.ssp"
        return PreparedRun(build_ssp(scn, ssp, to_disk=kept_after_run(task, ssp.name, self)), {}, None, {})

    def summary_rows(self, summary) -> list[tuple[str, dict]]:
        """One row per UAV of the monitor's summary, then the run's totals."""
        if not isinstance(summary, dict) or not summary.get("uavs"):
            return []
        rows = [(u.get(UAV_COLUMN), {k: v for k, v in u.items() if k != UAV_COLUMN}) for u in summary["uavs"]]
        total = dict(summary.get("total") or {})
        total.pop("run_outcome", None)      # the table's run_outcome column says it
        return rows + [(TOTAL_ROW, total)]

    def report(self, manifest: dict, df, out: Path) -> str | None:
        from .report import uav_report
        return uav_report(manifest, df, out)

    def claims_run(self, meta: dict) -> bool:
        """A run the UAV monitor observed (any SSP with its annotation: shipped, built or a campaign's)."""
        from .names import MONITOR_TYPE
        return MONITOR_TYPE in (meta.get("monitors") or {})

    def write_replay(self, run_dir: Path, scenario: Path | None = None) -> Path:
        from .replay import replay_run_folder
        return replay_run_folder(run_dir, scenario)


UAV_KIND = UavKind()
