"""Which parameter sets a campaign runs: the grid (the product of its axes), crossed with the configurations
of a ``design:`` (a baseline, one factor at a time around it, a factorial around it), and what a run's
configuration is in its design.

Here the design is already checked and canonical (``spec`` reads it from the campaign file).
"""
from __future__ import annotations

import itertools

from .identity import canonical_json

__all__ = ["DESIGN_KEYS", "design_points", "design_roles", "grid_points"]

#: the parts of ``design:`` (configurations, each crossed with the grid)
DESIGN_KEYS = ("baseline", "one_at_a_time", "factorial")


def design_points(design: dict) -> list[dict]:
    """The configurations of a design, each a full parameter set (every design parameter set): the baseline,
    then each one_at_a_time value in turn with every other parameter at its baseline, then the factorial
    product (first key slowest) around the baseline.  A configuration that an earlier part already has (the
    baseline value of a factor, a factorial corner on a one-at-a-time line) is the same runs and appears once."""
    base = dict(design["baseline"])
    points = [base]
    for key, vals in design.get("one_at_a_time", {}).items():
        points += [{**base, key: v} for v in vals]
    factorial = design.get("factorial", {})
    if factorial:
        points += [{**base, **dict(zip(factorial, combo))} for combo in itertools.product(*factorial.values())]
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
    factorial = design.get("factorial", {})
    if factorial and all(k in factorial for k in differ) and all(
            any(canonical_json(params.get(k)) == canonical_json(v) for v in factorial[k]) for k in factorial):
        roles.append("factorial")
    return roles


def grid_points(axes: list[tuple[str, list]], design: dict) -> list[dict]:
    """The parameter sets of the grid ``axes`` ([(key, values)], first axis slowest) crossed with the design's
    configurations (each configuration runs the whole grid); [] with neither."""
    if not axes and not design:
        return []
    keys = [k for k, _ in axes]
    points = design_points(design) if design else [{}]
    return [{**dict(zip(keys, combo)), **point}
            for point in points for combo in itertools.product(*[vals for _, vals in axes])]
