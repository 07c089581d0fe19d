"""The value-free part of a plan kept for later runs of the same structure and FMUs: a campaign worker plans the
same system against the same FMUs run after run, with other parameter values.  What it is keyed by
(:func:`plan_key`) and how a run gets its own copy of it (:meth:`_PlanStructure.for_run`)."""
from __future__ import annotations

from typing import NamedTuple

from ..errors import CosimError
from ..fmi.cache import load_fmu
from ..records import replaced
from ..ssp.model import CSV_SOURCE_TYPE, SystemModel
from .model import shown_source


class _PlanStructure(NamedTuple):
    """The value-free part of a plan (``build._plan_structure``) kept for later runs of the same structure and FMUs;
    never handed out itself: each run gets its own links, dependency sets and dictionaries. A named tuple, not a
    frozen dataclass (``master.records`` says why)."""
    kinds: dict             # component -> the FMI kind it runs as
    variables: dict         # component -> ComponentVariables (read-only mappings of frozen Vars)
    feedthrough: dict
    units: dict
    links: tuple

    def for_run(self, model: SystemModel, loaded: dict):
        """The run's own plan parts, with its FMUs (``loaded``: by file, as plan_key loaded them)."""
        fmus = {name: loaded[comp.fmu_path].as_kind(self.kinds[name])
                for name, comp in model.components.items()}
        return fmus, dict(self.variables), _copied_feedthrough(self.feedthrough), dict(self.units), \
            [replaced(ln) for ln in self.links]


# (structure key, each component's FMU content and kind asked for, lenient, units) -> _PlanStructure: a campaign
# worker plans the same system against the same FMUs run after run, with other parameter values
_PLANS: dict[tuple, _PlanStructure] = {}
_MAX_PLANS = 32
_MAX_KEPT_LINKS = 100_000       # links of all kept plans (4 UAVs: ~60; 256 UAVs: ~4000)


def _loaded_fmus(model: SystemModel, shown_as: str, lenient: bool) -> dict:
    """Each FMU file of the model, loaded (once per file: a fleet's components share a few)."""
    loaded = {}
    for comp in model.components.values():
        if comp.fmu_path not in loaded:
            loaded[comp.fmu_path] = load_fmu(comp.fmu_path, shown_source(shown_as, comp.source), lenient=lenient)
    return loaded


def plan_key(model: SystemModel, shown_as: str, lenient: bool, implementation: dict | None,
              inputs) -> tuple[tuple | None, dict]:
    """What the value-free part of the plan depends on: the structure, the FMUs by content, the options that
    change it, and the units (a parameter set may define some); with the FMUs loaded to find their contents.
    None: not to be reused (the model was not read for it, an input file or table is read per run, or an FMU
    fails to load: the full plan says why)."""
    if model.structure is None or inputs is not None:
        return None, {}
    if any(comp.type == CSV_SOURCE_TYPE for comp in model.components.values()):
        return None, {}
    try:
        loaded = _loaded_fmus(model, shown_as, lenient)
    except CosimError:
        return None, {}
    fmus = tuple((name, loaded[comp.fmu_path].sha256, (implementation or {}).get(name) or comp.implementation)
                 for name, comp in model.components.items())
    units = repr([(name, u.name, u.factor, u.offset, u.exponents) for name, u in model.units.items()])  # -0.0
    return (model.structure, fmus, bool(lenient), units), loaded


def kept_structure(key: tuple | None) -> _PlanStructure | None:
    """The structure kept under ``key`` (None: none, or not to be reused)."""
    return _PLANS.get(key) if key is not None else None


def keep_plan(key: tuple, fmus: dict, variables: dict, feed: dict, units: dict, links: list) -> None:
    if len(_PLANS) >= _MAX_PLANS or sum(len(p.links) for p in _PLANS.values()) + len(links) > _MAX_KEPT_LINKS:
        _PLANS.clear()          # emptied when full (a campaign plans a handful of systems): no order to keep
    if len(links) > _MAX_KEPT_LINKS:
        return
    _PLANS[key] = _PlanStructure({name: f.kind for name, f in fmus.items()}, dict(variables),
                                 _copied_feedthrough(feed), dict(units), tuple(replaced(ln) for ln in links))


def _copied_feedthrough(feed: dict) -> dict:
    return {comp: {out: None if deps is None else set(deps) for out, deps in outs.items()}
            for comp, outs in feed.items()}
