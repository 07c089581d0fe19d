"""Campaign files: reading and validating one into a :class:`Campaign`, an ordered list of :class:`RunSpec`,
one per (parameter set, repetition).

The format is documented in ``docs/campaigns.md``.  Every problem is one line (:class:`ScenarioError` naming
the file and the element at fault), found before anything runs.  The parts that are not about the file:

* :mod:`.identity` -- canonical JSON, run ids, seeds, input fingerprints;
* :mod:`.design` -- the grid crossed with a ``design:`` (baseline, one factor at a time, factorial);
* :mod:`.options` -- the run options and their checks.

The names they define are importable from here too, as they always were.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import yamlio
from ..errors import CosimError, ScenarioError
from ..scenario_kinds import SCENARIO_KINDS, ScenarioKind, kind_for_file
from .design import DESIGN_KEYS, design_points, design_roles, grid_points
from .identity import (REPORT_ONLY, SEED_MASK, canonical, canonical_json, code_sha256, digest, file_sha256,
                       run_id_for, run_id_of_canonical, scenario_sha256, seed_for, seed_of_canonical)
from .options import ALGORITHM_RUN_OPTIONS, RESULT_OPTIONS, RUN_OPTIONS, SCENARIO_OPTIONS, check_options

__all__ = ["Campaign", "RunSpec", "load_campaign", "is_campaign_document", "canonical", "canonical_json",
           "run_id_for", "seed_for", "RUN_OPTIONS", "RESULT_OPTIONS", "SCENARIO_OPTIONS", "design_points",
           "design_roles",
           # defined in .identity, .design and .options; imported from here by code written before the split
           "ALGORITHM_RUN_OPTIONS", "DESIGN_KEYS", "REPORT_ONLY", "SEED_MASK", "code_sha256", "file_sha256",
           "grid_points", "scenario_sha256"]

TOP_KEYS = ("name", "description", "seed", "repetitions", "scenario", "grid", "design", "runs", "run", "keep",
            "paired")
KEEP = ("summary", "all")
#: parameter names a campaign derives itself
DERIVED = ("seed", "rep", "run_id")


# ---------------------------------------------------------------------------------------------- model
@dataclass
class RunSpec:
    index: int                  # position in the campaign's run order
    run_id: str
    params: dict                # canonical parameters (grid / runs keys, variant by name)
    rep: int                    # repetition index, 0-based
    seed: int
    scenario: Path              # absolute path of the scenario this run starts from
    scenario_label: str         # the scenario as written in the campaign file
    options: dict               # effective run options (fixed run: options, overridden by params)
    overrides: dict             # the kind's scenario overrides (SSP: "component.variable" -> value)
    inputs: dict = field(default_factory=dict)

    @property
    def inputs_sha256(self) -> str:
        return digest(self.inputs)


@dataclass
class Campaign:
    path: Path
    name: str
    description: str
    seed: int
    repetitions: int
    kind: str                   # name of the scenario kind (master.scenario_kinds), e.g. "ssp"
    param_keys: list            # parameter column names, in file order
    keep: str
    options: dict               # fixed run options
    runs: list                  # [RunSpec] in run order
    text: str                   # the campaign file as read
    paired: list = field(default_factory=list)   # parameters left out of the seeds (common random numbers)
    design: dict = field(default_factory=dict)   # design: (baseline, one_at_a_time, factorial), canonical

    def manifest(self) -> dict:
        """What ``campaign.json`` holds: the resolved campaign, enough to rebuild the table and report."""
        return {"format": 1, "name": self.name, "description": self.description, "campaign_file": str(self.path),
                "seed": self.seed, "repetitions": self.repetitions, "kind": self.kind,
                "param_keys": list(self.param_keys), "paired": list(self.paired), "keep": self.keep,
                "design": self.design,
                "options": self.options,
                "runs": [{"run_id": r.run_id, "params": r.params, "rep": r.rep, "seed": r.seed,
                          "scenario": r.scenario_label, "inputs_sha256": r.inputs_sha256} for r in self.runs]}


class _FileErrors:
    """``err(element, reason)`` raises the one-line error of the campaign file at ``path``."""

    def __init__(self, path):
        self.path = str(path)

    def __call__(self, element: str, reason: str):
        raise ScenarioError(reason, file=self.path, element=element)


@dataclass
class _Scenarios:
    """The scenario files of a campaign, keyed by variant name (None: the base ``scenario:``)."""
    files: dict                 # variant -> absolute path
    labels: dict                # variant -> the path as written in the campaign file
    variants: dict              # variant name -> file as written (grid.variant)
    kind: ScenarioKind


# ---------------------------------------------------------------------------------------------- loading
def load_campaign(path) -> Campaign:
    """Read and validate a campaign file; errors are one-line :class:`ScenarioError`.  The steps run in the
    file's reading order, so that a file with several problems names the first."""
    path = Path(path)
    err = _FileErrors(path)
    text, data = _read_document(err, path)
    name, description, seed, repetitions, keep = _read_header(err, data)
    grid, explicit_runs = _read_grid_and_runs(err, data)
    scenarios = _read_scenarios(err, data, grid, path.resolve().parent)
    options = _read_run_options(err, data)
    axes = _grid_axes(err, grid, scenarios)
    param_keys = [k for k, _ in axes]
    design = _read_design(err, data.get("design"), scenarios.kind, param_keys)
    param_keys += list(design.get("baseline", {}))
    param_sets = grid_points(axes, design)
    origins = ["design" if design else "grid"] * len(param_sets)   # where each set comes from, for errors
    for i, entry in enumerate(explicit_runs):
        param_sets.append(_explicit_run(err, i, entry, scenarios, param_keys))
        origins.append(f"runs[{i}]")
    if not param_sets:
        param_sets, origins = [{}], ["scenario"]
    if scenarios.variants and None not in scenarios.files and any("variant" not in p for p in param_sets):
        err("runs", "a run without variant needs a base scenario (scenario:)")
    paired = _read_paired(err, data, param_keys)
    set_options = _check_parameter_sets(err, param_sets, origins, options)
    _check_with_kind(err, scenarios.kind, scenarios.files, scenarios.labels, param_sets, origins, set_options,
                     options)
    runs = _expand_runs(scenarios, param_sets, set_options, repetitions, seed, paired)
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):  # pragma: no cover - a 48-bit collision
        err("grid", "two runs got the same run id; change the campaign seed or a parameter spelling")
    return Campaign(path.resolve(), name, str(description), seed, repetitions, scenarios.kind.name, param_keys, keep,
                    options, runs, text, list(paired), design)


def _read_document(err, path: Path) -> tuple[str, dict]:
    """The file's text and its YAML mapping, with only campaign fields (a scenario file is named as one)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        err("file", f"cannot read: {exc.strerror or exc}")
    data = yamlio.load_text(text, path)
    if not isinstance(data, dict):
        err("(top level)", "expected a mapping (name, seed, repetitions, scenario, grid/runs, run, keep)")
    if any(k not in TOP_KEYS for k in data):
        _refuse_scenario_document(err, path, data)
    for k in data:
        if k not in TOP_KEYS:
            err(str(k), f"unknown field (expected one of {', '.join(TOP_KEYS)})")
    return text, data


def _read_header(err, data: dict) -> tuple[str, Any, int, int, str]:
    """name, description, seed, repetitions and keep."""
    name = data.get("name")
    if not isinstance(name, str) or not name.strip() or any(c in name for c in "/\\"):
        err("name", f"expected a non-empty name without slashes, got {name!r}")
    name = name.strip()
    description = data.get("description") or ""
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        err("seed", f"expected an integer >= 0, got {seed!r}")
    repetitions = data.get("repetitions", 1)
    if isinstance(repetitions, bool) or not isinstance(repetitions, int) or repetitions < 1:
        err("repetitions", f"expected an integer >= 1, got {repetitions!r}")
    keep = data.get("keep", "all")
    if keep not in KEEP:
        err("keep", f"must be one of {', '.join(KEEP)}, got {keep!r}")
    return name, description, seed, repetitions, keep


def _read_grid_and_runs(err, data: dict) -> tuple[dict, list]:
    grid = data.get("grid") or {}
    if not isinstance(grid, dict):
        err("grid", "expected a mapping of parameter -> value or list of values")
    explicit_runs = data.get("runs") or []
    if not isinstance(explicit_runs, list):
        err("runs", "expected a list of parameter mappings")
    return grid, explicit_runs


def _read_scenarios(err, data: dict, grid: dict, base_dir: Path) -> _Scenarios:
    """The base scenario and the variants (grid.variant), resolved against the campaign file's folder, all
    existing and of one kind."""
    variants: dict[str, str] = {}
    if "variant" in grid:
        v = grid["variant"]
        if isinstance(v, dict):
            variants = {str(k): str(x) for k, x in v.items()}
        elif isinstance(v, list):
            variants = {Path(str(x)).stem: str(x) for x in v}
        else:
            err("grid.variant", "expected a mapping name -> scenario file (or a list of files)")
        if not variants:
            err("grid.variant", "no variants")
    base_scenario = data.get("scenario")
    if base_scenario is None and not variants:
        err("scenario", "missing: give the base scenario (an SSP or a scenario of another kind), or grid.variant")
    files: dict[str | None, Path] = {}
    labels: dict[str | None, str] = {}
    if base_scenario is not None:
        files[None] = _resolve(base_dir, base_scenario)
        labels[None] = str(base_scenario)
    for variant, variant_file in variants.items():
        files[variant] = _resolve(base_dir, variant_file)
        labels[variant] = variant_file
    for variant, p in files.items():
        if not p.exists():
            err(_scenario_element(variant), f"scenario not found: {p}")
    kinds = {}
    for variant, p in files.items():
        try:
            kind = kind_for_file(p)
        except CosimError as exc:
            err(_scenario_element(variant), f"{p}: {exc.reason}")
        kinds[kind.name] = kind
    if len(kinds) != 1:
        err("grid.variant", f"all scenarios of a campaign must be of one kind (here: {', '.join(sorted(kinds))})")
    return _Scenarios(files, labels, variants, kinds.popitem()[1])


def _resolve(base_dir: Path, p) -> Path:
    p = Path(str(p)).expanduser()
    return (p if p.is_absolute() else base_dir / p).resolve()


def _read_run_options(err, data: dict) -> dict:
    """The fixed run options (``run:``), canonical and checked."""
    options = data.get("run") or {}
    if not isinstance(options, dict):
        err("run", "expected a mapping of run options")
    for k in options:
        if k not in RUN_OPTIONS:
            err(f"run.{k}", f"unknown run option (expected one of {', '.join(RUN_OPTIONS)})")
    for k, v in options.items():        # a value that is no number: said per option, not a traceback
        try:
            canonical(v)
        except ValueError as exc:
            err(f"run.{k}", str(exc))
    options = canonical(options)
    check_options(err, "run", options)
    return options


def _grid_axes(err, grid: dict, scenarios: _Scenarios) -> list[tuple[str, list]]:
    """The grid's axes in file order, (parameter, canonical values); the variant axis by variant name."""
    axes: list[tuple[str, list]] = []
    for k, v in grid.items():
        if k == "variant":
            axes.append(("variant", list(scenarios.variants)))
            continue
        key = _check_param_key(err, "grid", k, scenarios.kind)
        axes.append((key, _value_list(err, f"grid.{key}", v)))
    return axes


def _explicit_run(err, i: int, entry, scenarios: _Scenarios, param_keys: list) -> dict:
    """The parameter set of ``runs[i]``; a parameter it is the first to name joins ``param_keys``."""
    if not isinstance(entry, dict):
        err(f"runs[{i}]", "expected a mapping of parameter -> value")
    params = {}
    for k, v in entry.items():
        if k == "variant":
            if str(v) not in scenarios.variants:
                err(f"runs[{i}].variant", f"unknown variant {v!r} (defined in grid.variant: "
                                          f"{', '.join(scenarios.variants) or 'none'})")
            params["variant"] = str(v)
        else:
            key = _check_param_key(err, f"runs[{i}]", k, scenarios.kind)
            if isinstance(v, list) and key not in ("record",):
                err(f"runs[{i}].{key}", "one value per explicit run (use grid: for lists of values)")
            try:
                params[key] = canonical(v)
            except ValueError as exc:
                err(f"runs[{i}].{key}", str(exc))
        if k not in param_keys:
            param_keys.append(k if k == "variant" else k.strip())
    return params


def _read_paired(err, data: dict, param_keys: list) -> list:
    """The parameters left out of the seeds, so that runs differing only in them share their random numbers
    (common random numbers: strategy A and B meet the same wind)."""
    paired = data.get("paired") or []
    if isinstance(paired, str):
        paired = [paired]
    if not isinstance(paired, list) or not all(isinstance(k, str) for k in paired):
        err("paired", "expected a parameter name or a list of them")
    for k in paired:
        if k not in param_keys:
            err("paired", f"{k!r} is not a parameter of this campaign (parameters: {', '.join(param_keys) or 'none'})")
    return paired


def _check_parameter_sets(err, param_sets: list, origins: list, options: dict) -> list[dict]:
    """Every parameter set once and with valid run options, before anything runs; the effective run options of
    each set (the fixed ones overridden by its parameters)."""
    set_options: list[dict] = []
    seen: dict[str, int] = {}
    for index, (params, origin) in enumerate(zip(param_sets, origins)):
        key = canonical_json(params)
        if key in seen:
            err("runs", f"the parameter set {key} appears twice (a duplicate runs: entry, or one the grid "
                        "already has)")
        seen[key] = index
        opts = {**options, **{k: v for k, v in params.items() if k in RUN_OPTIONS}}
        check_options(err, origin, opts)
        set_options.append(opts)
    return set_options


def _expand_runs(scenarios: _Scenarios, param_sets: list, set_options: list, repetitions: int, seed: int,
                 paired: list) -> list[RunSpec]:
    """The runs in order (each parameter set, each repetition), with their ids, seeds and input fingerprints
    (each scenario file hashed once)."""
    kind = scenarios.kind
    scenario_hash = {k: scenario_sha256(p) for k, p in scenarios.files.items()}
    fmu_hash = {k: kind.input_fmus(p) for k, p in scenarios.files.items()}
    code = code_sha256()
    runs: list[RunSpec] = []
    for params, opts in zip(param_sets, set_options):
        variant = params.get("variant")
        label = scenarios.labels[variant]
        overrides = kind.overrides(_scenario_params(params), opts)
        # what the repetitions share, canonical once (the paper campaign: 24 repetitions of each set)
        cparams, cseeded = canonical(params), canonical({k: v for k, v in params.items() if k not in paired})
        shared = canonical({"scenario": label, "scenario_sha256": scenario_hash[variant], "fmus": fmu_hash[variant],
                            "options": {k: opts[k] for k in RESULT_OPTIONS if k in opts}, "overrides": overrides,
                            "code_sha256": code})
        for rep in range(repetitions):
            run_seed = seed_of_canonical(seed, cseeded, rep)
            inputs = dict(sorted({**shared, "seed": canonical(run_seed)}.items()))
            runs.append(RunSpec(len(runs), run_id_of_canonical(cparams, rep), params, rep, run_seed,
                                scenarios.files[variant], label, opts, overrides, inputs))
    return runs


# ---------------------------------------------------------------------------------------------- checks
def _check_param_key(err, where: str, key: Any, kind: ScenarioKind) -> str:
    if not isinstance(key, str) or not key.strip():
        err(where, f"parameter names must be non-empty strings, got {key!r}")
    key = key.strip()
    if key in DERIVED:
        err(f"{where}.{key}", "is derived by the campaign (seed from the campaign seed, rep from repetitions)"
                              " and cannot be set")
    why = kind.param_key_error(key)
    if why:
        err(f"{where}.{key}", why)
    return key


def _value_list(err, where: str, v) -> list:
    """A value or list of values, canonical, none twice."""
    values = v if isinstance(v, list) else [v]
    if not values:
        err(where, "empty list of values")
    out = []
    for x in values:
        try:
            out.append(canonical(x))
        except ValueError as exc:
            err(where, str(exc))
    seen = []
    for x in out:
        if canonical_json(x) in seen:
            err(where, f"duplicate value {x!r}")
        seen.append(canonical_json(x))
    return out


def _read_design(err, raw, kind: ScenarioKind, grid_keys: list) -> dict:
    """``design:`` checked and canonical: baseline (parameter -> one value), one_at_a_time and factorial
    (parameter -> list of values); every varied parameter has a baseline value, none is a grid axis."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        err("design", "expected a mapping with baseline, one_at_a_time and/or factorial")
    for k in raw:
        if k not in DESIGN_KEYS:
            err(f"design.{k}", f"unknown field (expected one of {', '.join(DESIGN_KEYS)})")
    baseline = raw.get("baseline") or {}
    if not isinstance(baseline, dict) or not baseline:
        err("design.baseline", "expected a mapping parameter -> value (the configuration every factor varies "
                               "around)")
    out: dict = {"baseline": {}, "one_at_a_time": {}, "factorial": {}}
    for k, v in baseline.items():
        key = _check_param_key(err, "design.baseline", k, kind)
        if key in grid_keys or key == "variant":
            err(f"design.baseline.{key}", "is a grid axis already; a parameter is either in grid: or in design:")
        if isinstance(v, list) and key != "record":
            err(f"design.baseline.{key}", "one value per parameter (the values to try go in one_at_a_time or "
                                          "factorial)")
        try:
            out["baseline"][key] = canonical(v)
        except ValueError as exc:
            err(f"design.baseline.{key}", str(exc))
    for part in ("one_at_a_time", "factorial"):
        values_of = raw.get(part) or {}
        if not isinstance(values_of, dict):
            err(f"design.{part}", "expected a mapping parameter -> list of values")
        for k, v in values_of.items():
            key = str(k).strip()
            if key not in out["baseline"]:
                err(f"design.{part}.{key}", "has no baseline value: add it to design.baseline")
            out[part][key] = _value_list(err, f"design.{part}.{key}", v)
    if not out["one_at_a_time"] and not out["factorial"]:
        err("design", "nothing to vary: give one_at_a_time and/or factorial")
    return out


def is_campaign_document(data) -> bool:
    """Does ``data`` (a YAML document as read) look like a campaign (a scenario never has these fields)?"""
    return isinstance(data, dict) and any(k in data for k in ("scenario", "grid", "design", "runs", "repetitions"))


def _refuse_scenario_document(err, path: Path, data: dict):
    """A scenario file given as the campaign: say what it is and where it goes, rather than listing the
    campaign fields it lacks."""
    for kind in SCENARIO_KINDS.load_all().values():
        if kind.is_scenario_document(data):
            build = (f", or build its SSP with `cosim-master build-scenario {path} -o x.ssp`"
                     if type(kind).build is not ScenarioKind.build else "")
            err("(top level)", f"this is a {kind.label} scenario file, not a campaign: name it in a campaign's "
                               f"scenario:{build}")


def _scenario_params(params: dict) -> dict:
    """The parameters a scenario kind applies to the scenario: without the variant and the run options."""
    return {k: v for k, v in params.items() if k != "variant" and k not in RUN_OPTIONS}


def _check_with_kind(err, kind: ScenarioKind, scenario_files: dict, labels: dict, param_sets: list,
                     origins: list, set_options: list, fixed_options: dict):
    """Let the kind check the parameter sets of each scenario file (one call per file: an SSP is read once), so
    that a misspelt name or a bad value fails here rather than in every run."""
    for variant, scenario in scenario_files.items():
        indices = [i for i, p in enumerate(param_sets) if p.get("variant") == variant]
        if not indices:
            continue
        try:
            problem = kind.check_params(scenario, [(_scenario_params(param_sets[i]), set_options[i])
                                                   for i in indices])
        except CosimError as exc:
            err(_scenario_element(variant), str(exc))
        if problem is not None:
            i = indices[problem.index]
            err(*_locate(problem, param_sets[i], origins[i], fixed_options, labels[variant]))


def _scenario_element(variant) -> str:
    return "scenario" if variant is None else f"grid.variant.{variant}"


def _locate(problem, params: dict, origin: str, fixed_options: dict, label: str) -> tuple[str, str]:
    """(element, reason) of a kind's problem with a parameter set: the grid or runs key at fault when there is
    one; otherwise the combination, spelled out, since only some grid points may fail."""
    if problem.key in params:
        return f"{origin}.{problem.key}", problem.reason
    element = f"run.{problem.key}" if problem.key in fixed_options else origin
    if params:
        return element, f"{problem.reason} (the run {canonical_json(params)} of {label})"
    return element, f"{problem.reason} (scenario {label})"
