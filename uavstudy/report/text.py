"""How the report writes its numbers: p-values, blocked effects, ratios and the n of a panel or table.

One place for these, so a figure caption, a table cell and a finding's evidence say the same thing the same way.
"""
from __future__ import annotations

import math

from master.campaign import blocked as bl

__all__ = ["p_text", "effect_text", "ratio_text", "n_text"]


def p_text(p: float) -> str:
    """A p-value in two significant digits, in scientific notation below 0.001 ("n/a" without a test)."""
    if not math.isfinite(p):
        return "n/a"
    return f"{p:.2g}" if p >= 0.001 else f"{p:.1e}"


def effect_text(e: bl.Effect, digits=2, unit="") -> str:
    """A blocked effect with its interval, its sign-flip p-value and the blocks it rests on."""
    return f"{e.fmt(digits, unit)}, p = {p_text(e.p)}, {e.n_blocks} blocks"


def ratio_text(num: int, den: int) -> str:
    """num / den as "2.50×"; a zero denominator has no ratio ("both 0", or "n/a" beside a non-zero numerator)."""
    if den:
        return f"{num / den:.2f}×"
    return "both 0" if num == 0 else "n/a: none in the denominator"


def n_text(r, u=None) -> str:
    """n of a panel or table: runs, UAV missions, configurations and layouts."""
    runs = int(len(r))
    missions = int(len(u)) if u is not None else int(r["n_uavs"].sum())
    cells = int(r["cell"].nunique()) if "cell" in r.columns else 0
    if "layout_id" in r.columns:
        n_layouts = r["layout_id"].nunique()
        layouts = f"{n_layouts} layout{'s' if n_layouts != 1 else ''}"
    else:
        n_areas = r["area"].nunique()
        layouts = f"1 fixed layout per area ({n_areas} area{'s' if n_areas != 1 else ''})"
    return f"n = {runs} runs, {missions} UAV missions, {cells} configurations, {layouts}"
