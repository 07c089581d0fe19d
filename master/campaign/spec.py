"""Campaign files: parsing, grid expansion, run identities, seeds and input fingerprints.

The format is documented in ``docs/campaigns.md``.  A campaign expands into an ordered list of
:class:`RunSpec`, one per (parameter set, repetition).  Everything that identifies a run is derived
from canonical JSON (sorted keys, integral floats written as integers) so that it does not depend on
the order of the grid keys or on how a number was spelled:

* ``run_id`` = first 12 hex digits of SHA-256 over ``{"params": ..., "rep": r}``;
* ``seed``   = first 8 hex digits (31 bits) of SHA-256 over ``{"campaign_seed": s, "params": ..., "rep": r}``.

Adding a value to a grid axis therefore adds runs without touching the identity or the seed of the
runs that were already there.  The *inputs* of a run (hashes of its scenario file and FMUs, the run
options that change its results, its seed) are fingerprinted separately: a finished run whose
fingerprint no longer matches is stale and runs again.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import yamlio
from ..algorithm_options import ALGORITHM_OPTIONS
from ..errors import CosimError, ScenarioError
from ..ssp.archive import file_sha256
from ..scenario_kinds import SCENARIO_KINDS, ScenarioKind, kind_for_file

__all__ = ["Campaign", "RunSpec", "load_campaign", "is_campaign_document", "canonical", "canonical_json",
           "run_id_for", "seed_for", "RUN_OPTIONS", "RESULT_OPTIONS", "SCENARIO_OPTIONS", "design_points",
           "design_roles"]

TOP_KEYS = ("name", "description", "seed", "repetitions", "scenario", "grid", "design", "runs", "run", "keep",
            "paired")
#: the parts of ``design:`` (configurations, each crossed with the grid)
DESIGN_KEYS = ("baseline", "one_at_a_time", "factorial")
#: fixed run options (``run:``), also allowed as grid/runs keys
#: the algorithms' settings (master.algorithm_options): run options too, and part of a run's results
ALGORITHM_RUN_OPTIONS = tuple(ALGORITHM_OPTIONS)
RUN_OPTIONS = ("stop_time", "start_time", "step", "algorithm", "record_interval", "record", "csv",
               "log_level", "timeout", "step_multiples") + ALGORITHM_RUN_OPTIONS
#: the run options that change a run's results (part of its input fingerprint)
RESULT_OPTIONS = ("stop_time", "start_time", "step", "algorithm", "record_interval", "record",
                  "step_multiples") + ALGORITHM_RUN_OPTIONS
#: the run options a scenario carries itself (an SSP's default experiment): a run option overrides them
SCENARIO_OPTIONS = ("stop_time", "step", "algorithm")
KEEP = ("summary", "all")
SEED_MASK = 0x7FFFFFFF          # FMI Integer parameters are 32-bit signed


# ---------------------------------------------------------------------------------------------- canonical
def canonical(v: Any) -> Any:
    """Canonical form of a parameter value: integral floats become ints, tuples lists, dict keys sorted."""
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return v
    if isinstance(v, int):
        return int(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"non-finite number {v!r}")
        return int(v) if v.is_integer() and abs(v) < 2 ** 53 else float(v)
    if isinstance(v, (list, tuple)):
        return [canonical(x) for x in v]
    if isinstance(v, dict):
        return {str(k): canonical(x) for k, x in sorted(v.items(), key=lambda kv: str(kv[0]))}
    return str(v)


def canonical_json(obj: Any) -> str:
    return json.dumps(canonical(obj), sort_keys=True, separators=(",", ":"), ensure_ascii=True)


def _sha(obj: Any) -> str:
    return hashlib.sha256(canonical_json(obj).encode("ascii")).hexdigest()


def run_id_for(params: dict, rep: int) -> str:
    return _sha({"params": params, "rep": int(rep)})[:12]


def seed_for(campaign_seed: int, params: dict, rep: int) -> int:
    return int(_sha({"campaign_seed": int(campaign_seed), "params": params, "rep": int(rep)})[:8], 16) & SEED_MASK


def scenario_sha256(path: Path) -> str:
    """Hash of a scenario file, or of an SSP folder without its FMUs (hashed one by one as inputs)."""
    return file_sha256(path) if path.is_file() else _tree_sha(path)


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
        import master
        kinds = SCENARIO_KINDS.load_all().values()
        roots = [Path(master.__file__).resolve().parent,
                 *(Path(root).resolve() for k in kinds for root in k.code_roots())]
        report_only = set(REPORT_ONLY).union(*(k.report_only for k in kinds))
        h = hashlib.sha256()
        for root in dict.fromkeys(roots):
            for f in sorted(list(root.rglob("*.py")) + list(root.rglob("*.c"))):
                rel = f"{root.name}/{f.relative_to(root).as_posix()}"
                if rel not in report_only and "__pycache__" not in rel:
                    h.update(rel.encode() + b"\0" + file_sha256(f).encode() + b"\0")
        _code_sha = h.hexdigest()
    return _code_sha


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
        return _sha(self.inputs)


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


class _Err:
    def __init__(self, path):
        self.path = str(path)

    def __call__(self, element: str, reason: str):
        raise ScenarioError(reason, file=self.path, element=element)


def _check_param_key(err, where: str, key: Any, kind: ScenarioKind) -> str:
    if not isinstance(key, str) or not key.strip():
        err(where, f"parameter names must be non-empty strings, got {key!r}")
    key = key.strip()
    if key in ("seed", "rep", "run_id"):
        err(f"{where}.{key}", "is derived by the campaign (seed from the campaign seed, rep from repetitions)"
                              " and cannot be set")
    why = kind.param_key_error(key)
    if why:
        err(f"{where}.{key}", why)
    return key


def _values(err, where: str, v) -> list:
    vals = v if isinstance(v, list) else [v]
    if not vals:
        err(where, "empty list of values")
    out = []
    for x in vals:
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


def _resolve(base_dir: Path, p) -> Path:
    p = Path(str(p)).expanduser()
    return (p if p.is_absolute() else base_dir / p).resolve()


def load_campaign(path) -> Campaign:
    """Read and validate a campaign file; errors are one-line :class:`ScenarioError`."""
    path = Path(path)
    err = _Err(path)
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
    base_dir = path.resolve().parent

    name = data.get("name")
    if not isinstance(name, str) or not name.strip() or any(c in name for c in "/\\"):
        err("name", f"expected a non-empty name without slashes, got {name!r}")
    name = name.strip()
    description = data.get("description") or ""
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        err("seed", f"expected an integer >= 0, got {seed!r}")
    reps = data.get("repetitions", 1)
    if isinstance(reps, bool) or not isinstance(reps, int) or reps < 1:
        err("repetitions", f"expected an integer >= 1, got {reps!r}")
    keep = data.get("keep", "all")
    if keep not in KEEP:
        err("keep", f"must be one of {', '.join(KEEP)}, got {keep!r}")

    # ---- scenario / variants
    grid = data.get("grid") or {}
    if not isinstance(grid, dict):
        err("grid", "expected a mapping of parameter -> value or list of values")
    runs_list = data.get("runs") or []
    if not isinstance(runs_list, list):
        err("runs", "expected a list of parameter mappings")
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
    scen_files: dict[str | None, Path] = {}
    labels: dict[str | None, str] = {}
    if base_scenario is not None:
        scen_files[None] = _resolve(base_dir, base_scenario)
        labels[None] = str(base_scenario)
    for vname, vfile in variants.items():
        scen_files[vname] = _resolve(base_dir, vfile)
        labels[vname] = vfile
    for key, p in scen_files.items():
        if not p.exists():
            err(_scenario_element(key), f"scenario not found: {p}")
    kinds = {}
    for key, p in scen_files.items():
        try:
            kind = kind_for_file(p)
        except CosimError as exc:
            err(_scenario_element(key), f"{p}: {exc.reason}")
        kinds[kind.name] = kind
    if len(kinds) != 1:
        err("grid.variant", f"all scenarios of a campaign must be of one kind (here: {', '.join(sorted(kinds))})")
    kind = kinds.popitem()[1]

    # ---- run options
    options = data.get("run") or {}
    if not isinstance(options, dict):
        err("run", "expected a mapping of run options")
    for k in options:
        if k not in RUN_OPTIONS:
            err(f"run.{k}", f"unknown run option (expected one of {', '.join(RUN_OPTIONS)})")
    options = canonical(options)
    _check_options(err, "run", options)

    # ---- parameter sets
    axes: list[tuple[str, list]] = []
    for k, v in grid.items():
        if k == "variant":
            axes.append(("variant", list(variants)))
            continue
        key = _check_param_key(err, "grid", k, kind)
        axes.append((key, _values(err, f"grid.{key}", v)))
    param_keys = [k for k, _ in axes]
    design = _read_design(err, data.get("design"), kind, param_keys)
    points = design_points(design) if design else [{}]
    param_keys += list(design.get("baseline", {}))
    psets: list[dict] = []
    origins: list[str] = []         # where each parameter set comes from, for errors: grid or runs[i]
    if axes or design:
        for point in points:
            for combo in itertools.product(*[vals for _, vals in axes]):
                psets.append({**dict(zip([k for k, _ in axes], combo)), **point})
                origins.append("design" if design else "grid")
    for i, entry in enumerate(runs_list):
        if not isinstance(entry, dict):
            err(f"runs[{i}]", "expected a mapping of parameter -> value")
        p = {}
        for k, v in entry.items():
            if k == "variant":
                if str(v) not in variants:
                    err(f"runs[{i}].variant", f"unknown variant {v!r} (defined in grid.variant: "
                                              f"{', '.join(variants) or 'none'})")
                p["variant"] = str(v)
            else:
                key = _check_param_key(err, f"runs[{i}]", k, kind)
                if isinstance(v, list) and key not in ("record",):
                    err(f"runs[{i}].{key}", "one value per explicit run (use grid: for lists of values)")
                try:
                    p[key] = canonical(v)
                except ValueError as exc:
                    err(f"runs[{i}].{key}", str(exc))
            if k not in param_keys:
                param_keys.append(k if k == "variant" else k.strip())
        psets.append(p)
        origins.append(f"runs[{i}]")
    if not psets:
        psets, origins = [{}], ["scenario"]
    if variants and None not in scen_files and any("variant" not in p for p in psets):
        err("runs", "a run without variant needs a base scenario (scenario:)")
    # ---- paired: parameters left out of the seed, so runs that differ only in them share their random
    # numbers (common random numbers: strategy A and B meet the same wind)
    paired = data.get("paired") or []
    if isinstance(paired, str):
        paired = [paired]
    if not isinstance(paired, list) or not all(isinstance(k, str) for k in paired):
        err("paired", "expected a parameter name or a list of them")
    for k in paired:
        if k not in param_keys:
            err("paired", f"{k!r} is not a parameter of this campaign (parameters: {', '.join(param_keys) or 'none'})")

    # ---- every parameter set once, before anything runs: unique, run options valid, and runnable on its
    # scenario as far as its kind can tell (a misspelt name or a bad value would otherwise fail every run)
    set_options: list[dict] = []
    seen: dict[str, int] = {}
    for pi, (params, origin) in enumerate(zip(psets, origins)):
        cj = canonical_json(params)
        if cj in seen:
            err("runs", f"the parameter set {cj} appears twice (a duplicate runs: entry, or one the grid "
                        "already has)")
        seen[cj] = pi
        opts = {**options, **{k: v for k, v in params.items() if k in RUN_OPTIONS}}
        _check_options(err, origin, opts)
        set_options.append(opts)
    _check_with_kind(err, kind, scen_files, labels, psets, origins, set_options, options)

    # ---- input fingerprints (hashes once per scenario file)
    scen_hash = {k: scenario_sha256(p) for k, p in scen_files.items()}
    fmu_hash = {k: kind.input_fmus(p) for k, p in scen_files.items()}

    runs: list[RunSpec] = []
    code = code_sha256()
    for params, opts in zip(psets, set_options):
        vkey = params.get("variant")
        overrides = kind.overrides(_scenario_params(params), opts)
        for rep in range(reps):
            rid = run_id_for(params, rep)
            s = seed_for(seed, {k: v for k, v in params.items() if k not in paired}, rep)
            inputs = {"scenario": labels[vkey], "scenario_sha256": scen_hash[vkey],
                      "fmus": fmu_hash[vkey],
                      "options": {k: opts[k] for k in RESULT_OPTIONS if k in opts},
                      "overrides": overrides, "seed": s, "code_sha256": code}
            runs.append(RunSpec(len(runs), rid, params, rep, s, scen_files[vkey], labels[vkey], opts, overrides,
                                canonical(inputs)))
    ids = [r.run_id for r in runs]
    if len(set(ids)) != len(ids):  # pragma: no cover - a 48-bit collision
        err("grid", "two runs got the same run id; change the campaign seed or a parameter spelling")
    return Campaign(path.resolve(), name, str(description), seed, reps, kind.name, param_keys, keep, options, runs, text,
                    list(paired), design)


# ---------------------------------------------------------------------------------------------- design
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
        spec = raw.get(part) or {}
        if not isinstance(spec, dict):
            err(f"design.{part}", "expected a mapping parameter -> list of values")
        for k, v in spec.items():
            key = str(k).strip()
            if key not in out["baseline"]:
                err(f"design.{part}.{key}", "has no baseline value: add it to design.baseline")
            out[part][key] = _values(err, f"design.{part}.{key}", v)
    if not out["one_at_a_time"] and not out["factorial"]:
        err("design", "nothing to vary: give one_at_a_time and/or factorial")
    return out


def design_points(design: dict) -> list[dict]:
    """The configurations of a design, each a full parameter set (every design parameter set): the baseline,
    then each one_at_a_time value in turn with every other parameter at its baseline, then the factorial
    product (first key slowest) around the baseline.  A configuration that an earlier part already has (the
    baseline value of a factor, a factorial corner on a one-at-a-time line) is the same runs and appears once."""
    base = dict(design["baseline"])
    points = [base]
    for key, vals in design.get("one_at_a_time", {}).items():
        points += [{**base, key: v} for v in vals]
    fac = design.get("factorial", {})
    if fac:
        points += [{**base, **dict(zip(fac, combo))} for combo in itertools.product(*fac.values())]
    unique: dict[str, dict] = {}
    for p in points:
        unique.setdefault(canonical_json(p), p)
    return list(unique.values())


def design_roles(params: dict, design: dict) -> list[str]:
    """What a run's configuration is in its campaign's design: ``baseline``, ``one_at_a_time:KEY`` (only KEY
    differs from the baseline) and/or ``factorial`` (a point of the factorial product); [] without a design."""
    if not design:
        return []
    base = design["baseline"]
    differ = [k for k in base if canonical_json(params.get(k)) != canonical_json(base[k])]
    roles = []
    if not differ:
        roles.append("baseline")
    elif len(differ) == 1 and differ[0] in design.get("one_at_a_time", {}):
        roles.append(f"one_at_a_time:{differ[0]}")
    fac = design.get("factorial", {})
    if fac and all(k in fac for k in differ) and all(
            any(canonical_json(params.get(k)) == canonical_json(v) for v in fac[k]) for k in fac):
        roles.append("factorial")
    return roles


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


def _check_with_kind(err, kind: ScenarioKind, scen_files: dict, labels: dict, psets: list, origins: list,
                     set_options: list, fixed_options: dict):
    """Let the kind check the parameter sets of each scenario file (one call per file: an SSP is read once)."""
    for vkey, scenario in scen_files.items():
        indices = [i for i, p in enumerate(psets) if p.get("variant") == vkey]
        if not indices:
            continue
        try:
            problem = kind.check_params(scenario, [(_scenario_params(psets[i]), set_options[i]) for i in indices])
        except CosimError as exc:
            err(_scenario_element(vkey), str(exc))
        if problem is not None:
            i = indices[problem.index]
            err(*_locate(problem, psets[i], origins[i], fixed_options, labels[vkey]))


def _scenario_element(vkey) -> str:
    return "scenario" if vkey is None else f"grid.variant.{vkey}"


def _locate(problem, params: dict, origin: str, fixed_options: dict, label: str) -> tuple[str, str]:
    """(element, reason) of a kind's problem with a parameter set: the grid or runs key at fault when there is
    one; otherwise the combination, spelled out, since only some grid points may fail."""
    if problem.key in params:
        return f"{origin}.{problem.key}", problem.reason
    element = f"run.{problem.key}" if problem.key in fixed_options else origin
    if params:
        return element, f"{problem.reason} (the run {canonical_json(params)} of {label})"
    return element, f"{problem.reason} (scenario {label})"


def _check_options(err, where, opts: dict):
    for k in ("stop_time", "step", "record_interval", "timeout"):
        if k in opts and (isinstance(opts[k], bool) or not isinstance(opts[k], (int, float)) or opts[k] <= 0):
            err(f"{where}.{k}", f"expected a positive number, got {opts[k]!r}")
    if "start_time" in opts and (isinstance(opts["start_time"], bool) or
                                 not isinstance(opts["start_time"], (int, float))):
        err(f"{where}.start_time", f"expected a number, got {opts['start_time']!r}")
    if "algorithm" in opts:
        from ..algorithms import ALGORITHMS
        if opts["algorithm"] not in ALGORITHMS:
            err(f"{where}.algorithm", f"must be one of {', '.join(ALGORITHMS.names())}, got {opts['algorithm']!r}")
    for name in ALGORITHM_RUN_OPTIONS:
        if name in opts:
            try:
                ALGORITHM_OPTIONS[name].parse(opts[name], f"{where}.{name}")
            except CosimError as exc:
                err(exc.element, exc.reason)
    if "csv" in opts and not isinstance(opts["csv"], bool):
        err(f"{where}.csv", f"expected true or false, got {opts['csv']!r}")
    if "log_level" in opts and opts["log_level"] not in ("debug", "info", "warning", "error", "none"):
        err(f"{where}.log_level", f"must be debug, info, warning, error or none, got {opts['log_level']!r}")
    if "record" in opts and not (isinstance(opts["record"], list) and all(isinstance(x, str) for x in opts["record"])):
        err(f"{where}.record", "expected a list of patterns")
    if "step_multiples" in opts and not (isinstance(opts["step_multiples"], dict) and
                                         all(isinstance(x, int) and not isinstance(x, bool) and x >= 1
                                             for x in opts["step_multiples"].values())):
        err(f"{where}.step_multiples", "expected a mapping component -> integer >= 1")


def _tree_sha(folder: Path) -> str:
    """Hash of an SSP folder: its SSD and SSV/SSM files (FMUs are hashed one by one)."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix.lower() != ".fmu":
            h.update(str(p.relative_to(folder)).encode() + b"\0" + file_sha256(p).encode())
    return h.hexdigest()
