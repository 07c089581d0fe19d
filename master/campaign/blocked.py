"""Blocked statistics for campaign reports: compare two levels of a factor inside a block, never across.

A *block* is what two runs share when their difference should measure only the factor under study: the
same random draws (a campaign ``paired:`` on the factor gives the runs that differ only in it the same
seed) and the same configuration (every other parameter).  Runs of one block are not independent
replicates; runs of different blocks are (each block has its own seed).

* :func:`paired_differences` -- one difference b - a per block (the rows of a block and level aggregated
  first, so members of one run, which share its random draws, count once);
* :func:`blocked_effect` -- the mean difference over blocks with (i) a t interval, stratified by
  configuration when strata are given (within-stratum variances only: unlike configurations are not pooled
  into one variance, Cochran, *Sampling Techniques*, 3rd ed., section 5.3, with Satterthwaite's degrees of
  freedom), (ii) a percentile bootstrap interval resampling blocks within strata, (iii) the two-sided
  sign-flip permutation p-value (exact up to 16 blocks, else 20 000 random flips, seeded), and the
  standardised effect d_z = mean / sd of the differences;
* :func:`stratified_mean_ci` -- a level (a mean over several configurations) as the mean of per-run values
  with a stratified t interval (strata: the configurations);
* :func:`agrees_by_value` -- does a published number lie in our interval widened by a stated tolerance.

numpy only (scipy is a test dependency); the tests check every formula against hand computation.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from . import stats as st

__all__ = ["Effect", "paired_differences", "blocked_effect", "stratified_mean_ci", "agrees_by_value",
           "sign_flip_p", "Agreement"]

PERMUTATIONS = 20000
BOOTSTRAPS = 2000


@dataclass
class Effect:
    estimate: float             # mean difference over blocks
    low: float                  # t interval (stratified when strata were given)
    high: float
    boot_low: float             # percentile bootstrap over blocks
    boot_high: float
    p: float                    # two-sided sign-flip permutation p-value
    n_blocks: int
    n_strata: int
    sd: float                   # sd of the block differences
    d_z: float                  # standardised effect: mean / sd (nan when sd == 0)

    @property
    def significant(self) -> bool:
        return math.isfinite(self.p) and self.p < 0.05

    def fmt(self, digits: int = 2, unit: str = "") -> str:
        if self.n_blocks == 0 or not math.isfinite(self.estimate):
            return "n/a"
        ci = f" [{self.low:.{digits}f}, {self.high:.{digits}f}]" if math.isfinite(self.low) else ""
        return f"{self.estimate:+.{digits}f}{unit}{ci}"


def paired_differences(frame, value: str, factor: str, a, b, block_cols: list[str], agg: str = "mean"):
    """DataFrame with the block columns and ``diff`` = (value of level b) - (value of level a) per block: the
    rows of each (block, level) aggregated by ``agg`` first (mean or sum); blocks missing a level are left
    out."""
    import pandas as pd
    d = frame[frame[factor].isin([a, b])]
    g = d.groupby(list(block_cols) + [factor], dropna=False)[value].agg(agg).unstack(factor)
    if a not in g.columns or b not in g.columns:
        return pd.DataFrame(columns=list(block_cols) + ["diff"])
    g = g.dropna(subset=[a, b])
    out = g.reset_index()[list(block_cols)].copy()
    out["diff"] = (g[b].astype(float) - g[a].astype(float)).to_numpy()
    return out


def sign_flip_p(d, seed: int = 0) -> float:
    """Two-sided p-value of the sign-flip permutation test of mean(d) = 0: under the null each block's
    difference is as likely negative as positive.  Exact (all 2^n flips) up to n = 16, else Monte Carlo
    with (count + 1) / (flips + 1)."""
    d = np.asarray(d, dtype=float)
    d = d[np.isfinite(d)]
    n = d.size
    if n == 0:
        return math.nan
    obs = abs(d.sum())
    tol = 1e-9 * max(1.0, float(np.abs(d).sum()))
    if n <= 16:
        signs = np.array(list(itertools.product((1.0, -1.0), repeat=n)))
        return float(np.mean(np.abs(signs @ d) >= obs - tol))
    rng = np.random.default_rng(seed)
    signs = rng.choice((1.0, -1.0), size=(PERMUTATIONS, n))
    return float((np.sum(np.abs(signs @ d) >= obs - tol) + 1) / (PERMUTATIONS + 1))


def _strata_codes(strata, n: int) -> np.ndarray:
    if strata is None:
        return np.zeros(n, dtype=int)
    labels = [str(s) for s in strata]
    index = {s: i for i, s in enumerate(dict.fromkeys(labels))}
    return np.array([index[s] for s in labels], dtype=int)


def _stratified(values: np.ndarray, codes: np.ndarray, level: float, weights=None) -> tuple[float, float, float]:
    """(mean, low, high): stratum weights w_c = n_c / n (or the share of ``weights``, e.g. UAVs per run, so that
    the mean is the mean over missions), mean sum w_c mean_c, variance sum w_c^2 s_c^2 / n_c, Satterthwaite
    df.  Strata with one value get the pooled within-stratum variance of the others."""
    wts = np.ones(values.size) if weights is None else np.asarray(weights, dtype=float)
    ids = np.unique(codes)
    cells = [values[codes == c] for c in ids]
    share = np.array([wts[codes == c].sum() for c in ids]) / wts.sum()
    mean = float(sum(w * x.mean() for w, x in zip(share, cells)))
    multi = [x for x in cells if x.size > 1]
    if not multi:
        return mean, math.nan, math.nan
    pooled = sum(((x - x.mean()) ** 2).sum() for x in multi) / sum(x.size - 1 for x in multi)
    terms, dfs = [], []
    for w, x in zip(share, cells):
        s2 = float(x.var(ddof=1)) if x.size > 1 else pooled
        terms.append(w ** 2 * s2 / x.size)
        dfs.append(max(1, x.size - 1) if x.size > 1 else sum(y.size - 1 for y in multi))
    var = float(sum(terms))
    if var == 0.0:
        return mean, mean, mean
    df = var ** 2 / sum(t * t / k for t, k in zip(terms, dfs) if t > 0)
    h = st.t_ppf(0.5 + level / 2.0, df) * math.sqrt(var)
    return mean, mean - h, mean + h


def blocked_effect(diffs, strata=None, level: float = 0.95, seed: int = 0) -> Effect:
    """The mean of the block differences ``diffs`` with its intervals and permutation p-value (module
    docstring).  ``strata``: one label per block (its configuration), or None for one stratum."""
    d = np.asarray(diffs, dtype=float)
    keep = np.isfinite(d)
    codes = _strata_codes(strata, d.size)[keep]
    d = d[keep]
    n = d.size
    if n == 0:
        return Effect(math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, 0, 0, math.nan, math.nan)
    mean, low, high = _stratified(d, codes, level)
    sd = float(d.std(ddof=1)) if n > 1 else math.nan
    rng = np.random.default_rng(seed)
    groups = [np.flatnonzero(codes == c) for c in np.unique(codes)]
    boots = np.zeros(BOOTSTRAPS)
    for g in groups:        # resample each stratum's blocks with replacement, all bootstrap samples at once
        boots += d[g][rng.integers(0, g.size, size=(BOOTSTRAPS, g.size))].sum(axis=1)
    boots /= n
    q = (1.0 - level) / 2.0
    return Effect(mean, low, high, float(np.quantile(boots, q)), float(np.quantile(boots, 1 - q)),
                  sign_flip_p(d, seed), n, len(groups), sd, mean / sd if sd and math.isfinite(sd) else math.nan)


def stratified_mean_ci(values, strata=None, level: float = 0.95, floor: float | None = None,
                       ceiling: float | None = None, weights=None) -> st.CI:
    """Mean of ``values`` (one per run) with the stratified t interval (strata: the configurations pooled
    into this mean; ``weights``: see _stratified), cut to [floor, ceiling]."""
    v = np.asarray(values, dtype=float)
    keep = np.isfinite(v)
    codes = _strata_codes(strata, v.size)[keep]
    w = None if weights is None else np.asarray(weights, dtype=float)[keep]
    v = v[keep]
    if v.size == 0:
        return st.CI(math.nan, math.nan, math.nan, 0)
    mean, low, high = _stratified(v, codes, level, w)
    if math.isfinite(low):
        low = low if floor is None else max(floor, low)
        high = high if ceiling is None else min(ceiling, high)
    return st.CI(mean, low, high, int(v.size))


@dataclass
class Agreement:
    agrees: bool | None
    text: str


def agrees_by_value(paper: float, ours: st.CI | float, tolerance: float) -> Agreement:
    """Does the paper's value lie within our 95 % interval widened by ``tolerance`` on both sides (or, without
    an interval, within ``tolerance`` of our value)?  The text states the gap and the tolerance."""
    if isinstance(ours, st.CI):
        est, low, high = ours.estimate, ours.low, ours.high
    else:
        est, low, high = float(ours), math.nan, math.nan
    if not math.isfinite(est):
        return Agreement(None, "no value of ours")
    if not math.isfinite(low):
        low = high = est
    ok = low - tolerance <= paper <= high + tolerance
    return Agreement(ok, f"ours - paper = {est - paper:+.3g} (tolerance ±{tolerance:g} around our interval)")
