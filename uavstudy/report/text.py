"""How the report writes its numbers: p-values, statistics over layouts, ratios and the n of a panel or table.

One place for these, so a figure caption, a table cell and a finding's evidence say the same thing the same way.
Numbers are written with a fixed number of decimals and never as floating-point noise (no "-5.68e-14").
"""
from __future__ import annotations

import math

from master.campaign import stats as st

__all__ = ["p_text", "ci_text", "ratio_text", "n_text", "num"]


def num(x: float, digits: int = 2, signed: bool = False) -> str:
    """A number with ``digits`` decimals; what rounds to zero is 0."""
    return st.fmt_number(float(x), digits, signed) if x is not None else "n/a"


def p_text(p: float) -> str:
    """A p-value in two significant digits, "< 0.0001" below that ("n/a" without a test)."""
    if not math.isfinite(p):
        return "n/a"
    if p < 1e-4:
        return "< 0.0001"
    return f"{p:.2g}" if p >= 0.001 else f"{p:.1g}"


def ci_text(c: st.LayoutCI, digits=2, unit="", show_n: bool = True) -> str:
    """A statistic over layouts with its interval, its t-test p-value (when it has a null) and its n."""
    if c.n == 0 or not math.isfinite(c.estimate):
        return "n/a"
    signed = c.null == 0.0
    s = num(c.estimate, digits, signed) + unit
    if math.isfinite(c.low):
        s += f" [{_bound(c.low, digits, c.null)}, {_bound(c.high, digits, c.null)}]"
    elif c.n >= 2:
        s += " [unbounded]"
    if c.null is not None and math.isfinite(c.p):
        pt = p_text(c.p)
        s += f", p {pt}" if pt.startswith("<") else f", p = {pt}"
    return s + (f", {c.n} layout{'s' if c.n != 1 else ''}" if show_n else "")


def _bound(x: float, digits: int, null) -> str:
    """An interval bound with as many more decimals as it takes (up to 4) not to print it on the null when it
    is not on it: [-7.4, -0.04] must not read [-7.4, 0.0] beside a p-value below 0.05."""
    d = digits
    while null is not None and x != null and round(x, d) == round(null, d) and d < digits + 4:
        d += 1
    return num(x, d)


def ratio_text(num_: int, den: int) -> str:
    """num / den as "2.50×"; a zero denominator has no ratio ("both 0", or "n/a" beside a non-zero numerator)."""
    if den:
        return f"{num_ / den:.2f}×"
    return "both 0" if num_ == 0 else "n/a: none in the denominator"


def n_text(r, u=None) -> str:
    """n of a panel or table: runs, UAV missions, configurations and independent layouts."""
    runs = int(len(r))
    missions = int(len(u)) if u is not None else int(r["n_uavs"].sum())
    cells = int(r["cell"].nunique()) if "cell" in r.columns else 0
    n_layouts = int(r["layout"].nunique()) if "layout" in r.columns else 0
    if "layout_id" in r.columns and r["layout"].astype(str).str.startswith("random").all():
        layouts = f"{n_layouts} independent layout{'s' if n_layouts != 1 else ''}"
    else:
        layouts = f"{n_layouts} repetition{'s' if n_layouts != 1 else ''} of one fixed area per variant"
    return f"n = {runs} runs, {missions} UAV missions, {cells} configurations, {layouts}"
