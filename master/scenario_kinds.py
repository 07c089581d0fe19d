"""Scenario kinds: the ways of describing a scenario that campaigns and ``cosim-master build-scenario`` accept.

The engine runs SSPs.  A scenario kind is a file format a study puts on top of them (the UAV study's YAML
scenarios) together with everything a campaign has to know about it: which parameter names a grid may
vary, which inputs fingerprint a run, how one run's scenario is prepared, which code its results depend
on, how a run summary splits into table rows and how the campaign report reads.  Campaigns go through the
kind object only, so the engine never knows a study's names.

Every kind is published under the entry point group ``cosim_master.scenario_kinds`` (name = the kind, value = a
:class:`ScenarioKind` instance), the built-in ``ssp`` (:mod:`master.campaign.ssp_kind`, in this package's
pyproject.toml) as the study's ``uav``: the kinds build on the campaign machinery, which looks kinds up here, so
this registry imports none of them.  The kind of a campaign is recorded in its campaign.json, so the report finds
it again.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

from .errors import CosimError
from .registry import Registry


class PreparedRun(NamedTuple):
    """What ``master.run`` gets for one campaign run."""
    scenario: Path          # the SSP (archive, folder or .ssd) to run
    params: dict            # "component.variable" -> value
    seed: int | None        # given to every parameter named 'seed'; None when the scenario carries the seed
    options: dict           # further ``master.run`` keyword arguments (stop_time, step, algorithm, ...)


class ParamProblem(NamedTuple):
    """Why one parameter set of a campaign cannot run (:meth:`ScenarioKind.check_params`)."""
    index: int              # the parameter set, by its position in the list checked
    key: str | None         # the parameter or run option at fault; None: the combination as a whole
    reason: str


class ScenarioKind:
    name = ""
    label = ""                          # how messages call its scenarios ("SSP", "UAV YAML")
    #: the table column naming the member a summary row belongs to (one row per member and a total per
    #: run, see :meth:`summary_rows`); None: one row per run
    member_column: str | None = None
    #: whether a run's record keeps the last value of every recorded variable (its only result when no
    #: monitor summarises the run)
    records_final_values = True
    #: files under :meth:`code_roots` ("package/module.py") that only read finished records: editing them
    #: leaves the runs' results current
    report_only: tuple[str, ...] = ()
    #: files of a run folder that ``keep: summary`` keeps besides the engine's (run.json, summary.json, ...)
    summary_files: tuple[str, ...] = ()
    #: modules a campaign worker's runs of this kind import (its build, its monitors): the campaign's fork server
    #: imports them once for every worker it forks (master/campaign/worker_preload.py), instead of each worker in
    #: its first run
    worker_modules: tuple[str, ...] = ()

    def claims(self, path: Path) -> bool:
        """Is ``path`` a scenario of this kind?"""
        raise NotImplementedError

    def build(self, source: Path, output: Path) -> Path:
        """Write the SSP of the scenario ``source`` to ``output`` (``cosim-master build-scenario``)."""
        raise CosimError(f"{self.label} scenarios are run as they are: there is nothing to build",
                         file=str(source))

    # -- campaign definition -----------------------------------------------------------------------------
    def param_key_error(self, key: str) -> str | None:
        """Why ``key`` cannot be a campaign parameter of this kind (None: it can)."""
        raise NotImplementedError

    def check_params(self, scenario: Path, param_sets: list[tuple[dict, dict]]) -> ParamProblem | None:
        """The first parameter set that cannot run on ``scenario``, and why (None: all can).  Each set is
        (parameters, effective run options) as given to :meth:`overrides`.  Called when the campaign is
        loaded, so a misspelt name or a bad value is refused before anything runs instead of failing every
        run it is in; raises a :class:`CosimError` naming ``scenario`` when the scenario cannot be read."""
        return None

    def is_scenario_document(self, data) -> bool:
        """Is ``data`` (a YAML document as read) a scenario of this kind?  Lets ``cosim-master campaign``
        given a scenario file say so instead of listing the campaign fields the file lacks."""
        return False

    def overrides(self, params: dict, options: dict) -> dict:
        """A run's scenario overrides from its parameters (run options and the variant already taken out)
        and its effective run options."""
        raise NotImplementedError

    def input_fmus(self, scenario: Path) -> dict:
        """SHA-256 of every FMU a run of ``scenario`` loads, by name: part of the run's input fingerprint."""
        raise NotImplementedError

    def code_roots(self) -> list[Path]:
        """Package folders besides ``master`` whose code a run executes (hashed into ``code_sha256``)."""
        return []

    # -- one run ------------------------------------------------------------------------------------------
    def prepare_run(self, task: dict, out: Path, used: dict) -> PreparedRun:
        """The run of a campaign task (see ``master.campaign.runner.make_task``) in its folder ``out``;
        records in ``used["scenario_sha256"]`` the hash of the scenario file as read."""
        raise NotImplementedError

    # -- results ------------------------------------------------------------------------------------------
    def summary_rows(self, summary) -> list[tuple[str, dict]]:
        """(member, metrics) table rows of a run's summary.json, the run's total last; [] when the summary
        holds none (the run has one row)."""
        return []

    def report(self, manifest: dict, df, out: Path) -> str | None:
        """The markdown of the campaign report (figures written into ``out``), or None for the generic one."""
        return None

    # -- a finished run's folder --------------------------------------------------------------------------
    def claims_run(self, meta: dict) -> bool:
        """Did a run of this kind fill the run folder whose run.json holds ``meta`` (``cosim-master replay``)?"""
        return False

    def write_replay(self, run_dir: Path, scenario: Path | None = None) -> Path:
        """Write the replay page of the finished run in ``run_dir`` from its files (``scenario``: the one the run
        flew, when run.json's path no longer finds it); returns the page's path."""
        raise CosimError(f"{self.label} runs have no replay page", file=str(run_dir))


SCENARIO_KINDS: Registry[ScenarioKind] = Registry("scenario kind", "cosim_master.scenario_kinds")


def kind_claiming(path: Path) -> ScenarioKind | None:
    """The scenario kind that claims ``path`` (None when none does)."""
    for kind in SCENARIO_KINDS.load_all().values():
        if kind.claims(path):
            return kind
    return None


def kind_for_file(path: Path, element: str | None = None) -> ScenarioKind:
    """:func:`kind_claiming`, or a one-line error naming the file and the known kinds."""
    kind = kind_claiming(path)
    if kind is None:
        raise CosimError(f"no scenario kind claims this file (kinds: {', '.join(SCENARIO_KINDS.names())})",
                         file=str(path), element=element)
    return kind


def kind_for_run(run_dir: Path) -> ScenarioKind:
    """The scenario kind that claims the finished run in ``run_dir`` (by its run.json), or a one-line error."""
    import json
    try:
        meta = json.loads((Path(run_dir) / "run.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CosimError(f"not a run folder: cannot read its run.json ({type(exc).__name__})",
                         file=str(run_dir)) from None
    for kind in SCENARIO_KINDS.load_all().values():
        if isinstance(meta, dict) and kind.claims_run(meta):
            return kind
    raise CosimError(f"no scenario kind claims this run (kinds: {', '.join(SCENARIO_KINDS.names())}); a replay "
                     "page is written for the runs of a study that has one, e.g. UAV runs", file=str(run_dir))
