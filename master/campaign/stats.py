"""Small, dependency-free statistics for campaign reports (scipy is not a runtime dependency).

* :func:`t_ppf` -- Student t quantile (regularized incomplete beta, inverted by bisection);
* :func:`mean_ci` -- mean with a two-sided t interval ``mean +- t(1-a/2, n-1) s / sqrt(n)``;
* :func:`total_ci` -- a total over n runs as ``n * mean_ci`` (same interval scaled);
* :func:`wilson_ci` -- Wilson score interval of a proportion;
* :func:`fisher_exact` -- two-sided Fisher exact test of a 2x2 table (scipy's convention: the sum of
  the probabilities of every table at most as probable as the observed one, relative tolerance 1e-7);
* :func:`mann_whitney_u` -- two-sided Mann-Whitney U test as scipy's ``method="auto"``: exact null
  distribution when either sample has at most 8 values and there are no ties, else the normal
  approximation with tie correction and continuity correction;
* :func:`wilcoxon_signed_rank` -- two-sided Wilcoxon signed-rank test of paired differences (zeros dropped;
  exact for up to 50 differences without ties, else normal with tie correction, as scipy's "approx");
* :func:`mcnemar_exact` -- two-sided exact McNemar test of paired yes/no outcomes;
* :func:`ols_slope` -- least-squares slope with its t interval.

The test suite checks every function against scipy.stats and against hand computation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["t_ppf", "t_cdf", "norm_ppf", "mean_ci", "total_ci", "wilson_ci", "fisher_exact", "mann_whitney_u",
           "wilcoxon_signed_rank", "mcnemar_exact", "ols_slope", "CI"]

Z975 = 1.959963984540054


@dataclass
class CI:
    estimate: float
    low: float
    high: float
    n: int

    def fmt(self, digits: int = 2, unit: str = "") -> str:
        if self.n == 0 or not math.isfinite(self.estimate):
            return "n/a"
        if not math.isfinite(self.low):
            return f"{self.estimate:.{digits}f}{unit}"
        return f"{self.estimate:.{digits}f}{unit} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


# ----------------------------------------------------------------------------------- distributions
def _betacf(a: float, b: float, x: float) -> float:
    """Continued fraction of the incomplete beta function (modified Lentz)."""
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = tiny if abs(d) < tiny else d
    d = 1.0 / d
    h = d
    for m in range(1, 400):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = tiny if abs(d) < tiny else d
        c = 1.0 + aa / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = tiny if abs(d) < tiny else d
        c = 1.0 + aa / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        de = d * c
        h *= de
        if abs(de - 1.0) < 1e-15:
            break
    return h


def betainc(a: float, b: float, x: float) -> float:
    """Regularized incomplete beta I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    lbt = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(lbt) * _betacf(a, b, x) / a
    return 1.0 - math.exp(lbt) * _betacf(b, a, 1.0 - x) / b


def t_cdf(t: float, df: float) -> float:
    if math.isinf(df):
        return 0.5 * math.erfc(-t / math.sqrt(2.0))
    x = df / (df + t * t)
    tail = 0.5 * betainc(df / 2.0, 0.5, x)
    return 1.0 - tail if t > 0 else tail


def t_ppf(p: float, df: float) -> float:
    """Quantile of Student's t with df degrees of freedom (|error| < 1e-12)."""
    if not 0.0 < p < 1.0:
        raise ValueError("p must be in (0, 1)")
    if p == 0.5:
        return 0.0
    if p < 0.5:
        return -t_ppf(1.0 - p, df)
    lo, hi = 0.0, 1.0
    while t_cdf(hi, df) < p:
        hi *= 2.0
        if hi > 1e12:
            return math.inf
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if t_cdf(mid, df) < p:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-13 * max(1.0, hi):
            break
    return 0.5 * (lo + hi)


def norm_sf(z: float) -> float:
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def norm_ppf(p: float) -> float:
    return t_ppf(p, math.inf) if p != 0.975 else Z975


# ----------------------------------------------------------------------------------- intervals
def _clean(values) -> np.ndarray:
    a = np.asarray(list(values), dtype=float)
    return a[np.isfinite(a)]


def _clip(low: float, high: float, floor: float | None, ceiling: float | None) -> tuple[float, float]:
    """An interval cut to the values the quantity can take (e.g. [0, 100] for a percentage)."""
    if floor is not None:
        low = max(floor, low)
    if ceiling is not None:
        high = min(ceiling, high)
    return low, high


def mean_ci(values, level: float = 0.95, floor: float | None = None, ceiling: float | None = None) -> CI:
    """Mean and its t interval; n = 1 gives an unbounded interval (reported as the value alone).
    ``floor`` / ``ceiling``: truncate the interval there (0 for quantities that cannot be negative, 100 for
    percentages)."""
    a = _clean(values)
    n = a.size
    if n == 0:
        return CI(math.nan, math.nan, math.nan, 0)
    m = float(a.mean())
    if n == 1:
        return CI(m, math.nan, math.nan, 1)
    s = float(a.std(ddof=1))
    h = t_ppf(0.5 + level / 2.0, n - 1) * s / math.sqrt(n)
    return CI(m, *_clip(m - h, m + h, floor, ceiling), n)


def total_ci(values, level: float = 0.95, floor: float | None = None, ceiling: float | None = None) -> CI:
    """Sum of n per-run values, with the t interval of the mean scaled by n.  ``floor`` bounds the per-run
    mean (as in mean_ci), ``ceiling`` the total (e.g. the number of UAVs that flew, for UAVs removed)."""
    c = mean_ci(values, level, floor)
    if c.n == 0:
        return CI(0.0, math.nan, math.nan, 0)
    return CI(c.estimate * c.n, *_clip(c.low * c.n, c.high * c.n, None, ceiling), c.n)


def wilson_ci(successes: int, n: int, level: float = 0.95) -> CI:
    """Wilson score interval of the proportion successes / n."""
    if n <= 0:
        return CI(math.nan, math.nan, math.nan, 0)
    z = Z975 if level == 0.95 else t_ppf(0.5 + level / 2.0, math.inf)
    p = successes / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return CI(p, max(0.0, centre - half), min(1.0, centre + half), n)


# ----------------------------------------------------------------------------------- tests
def fisher_exact(a: int, b: int, c: int, d: int) -> float:
    """Two-sided p-value of Fisher's exact test of the table [[a, b], [c, d]]."""
    n1, n2, k = a + b, c + d, a + c          # row totals, first column total
    big_n = n1 + n2
    lo, hi = max(0, k - n2), min(k, n1)

    def weight(x):
        return math.comb(n1, x) * math.comb(n2, k - x)

    total = math.comb(big_n, k)
    w_obs = weight(a)
    p = sum(weight(x) for x in range(lo, hi + 1) if weight(x) <= w_obs * (1 + 1e-7))
    return min(1.0, p / total)


def _ranks(values: np.ndarray):
    order = np.argsort(values, kind="mergesort")
    ranks = np.empty(values.size, dtype=float)
    sv = values[order]
    i = 0
    ties = []
    while i < sv.size:
        j = i
        while j + 1 < sv.size and sv[j + 1] == sv[i]:
            j += 1
        ranks[order[i:j + 1]] = 0.5 * (i + j) + 1.0
        ties.append(j - i + 1)
        i = j + 1
    return ranks, np.asarray(ties, dtype=float)


def _mwu_exact_sf(u: int, n1: int, n2: int) -> float:
    """P(U >= u) under H0, from the coefficients of the Gaussian binomial [n1 + n2 choose n1]_q."""
    size = n1 * n2 + 1
    poly = [0] * size
    poly[0] = 1
    for i in range(1, n1 + 1):
        # multiply by (1 - q^(n2 + i))
        s = n2 + i
        for k in range(size - 1, s - 1, -1):
            poly[k] -= poly[k - s]
        # divide by (1 - q^i): running sum with stride i
        for k in range(i, size):
            poly[k] += poly[k - i]
    total = math.comb(n1 + n2, n1)
    return sum(poly[max(0, u):]) / total


def mann_whitney_u(x, y) -> tuple[float, float]:
    """Two-sided Mann-Whitney U test; returns (U of x, p-value)."""
    x, y = _clean(x), _clean(y)
    n1, n2 = x.size, y.size
    if n1 == 0 or n2 == 0:
        return math.nan, math.nan
    ranks, ties = _ranks(np.concatenate([x, y]))
    r1 = float(ranks[:n1].sum())
    u1 = r1 - n1 * (n1 + 1) / 2.0
    u2 = n1 * n2 - u1
    u = max(u1, u2)
    has_ties = bool((ties > 1).any())
    if (n1 > 8 and n2 > 8) or has_ties:
        n = n1 + n2
        tie_term = float((ties ** 3 - ties).sum())
        s = math.sqrt(n1 * n2 / 12.0 * ((n + 1) - tie_term / (n * (n - 1))))
        if s == 0:
            return u1, 1.0
        z = (u - n1 * n2 / 2.0 - 0.5) / s
        p = 2.0 * norm_sf(z)
    else:
        p = 2.0 * _mwu_exact_sf(int(round(u)), n1, n2)
    return u1, float(min(1.0, max(0.0, p)))


def _signed_rank_exact_cdf(t: int, n: int) -> float:
    """P(T+ <= t) under H0 for n non-zero differences without ties: count the subsets of {1..n} with sum <= t."""
    top = n * (n + 1) // 2
    counts = [0] * (top + 1)
    counts[0] = 1
    for k in range(1, n + 1):
        for s in range(top, k - 1, -1):
            counts[s] += counts[s - k]
    return sum(counts[:max(0, t) + 1]) / 2.0 ** n


def wilcoxon_signed_rank(d) -> tuple[float, float, str]:
    """Two-sided Wilcoxon signed-rank test of paired differences ``d`` (zeros dropped, as scipy's
    ``zero_method="wilcox"``); returns (T+ = sum of the ranks of the positive differences, p-value, method).
    Exact null distribution for at most 50 differences without ties (method "exact"), else the normal
    approximation with the tie correction of the variance and no continuity correction (scipy's
    ``method="approx"``, ``correction=False``): mid-ranks make the exact distribution invalid with ties."""
    d = _clean(d)
    d = d[d != 0.0]
    n = d.size
    if n == 0:
        return math.nan, math.nan, "none"
    ranks, ties = _ranks(np.abs(d))
    t_plus = float(ranks[d > 0].sum())
    if n <= 50 and not (ties > 1).any():
        t = int(round(t_plus))
        top = n * (n + 1) // 2
        p = 2.0 * min(_signed_rank_exact_cdf(t, n), _signed_rank_exact_cdf(top - t, n))
        return t_plus, float(min(1.0, p)), "exact"
    mean = n * (n + 1) / 4.0
    var = n * (n + 1) * (2 * n + 1) / 24.0 - float((ties ** 3 - ties).sum()) / 48.0
    if var <= 0:
        return t_plus, 1.0, "approx"
    z = (t_plus - mean) / math.sqrt(var)
    return t_plus, float(min(1.0, 2.0 * norm_sf(abs(z)))), "approx"


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar test: b and c are the discordant pairs (first yes / second no, and the
    reverse); under H0 min(b, c) is Binomial(b + c, 1/2)."""
    n = int(b) + int(c)
    if n == 0:
        return 1.0
    k = min(int(b), int(c))
    return float(min(1.0, 2.0 * sum(math.comb(n, i) for i in range(k + 1)) / 2.0 ** n))


def ols_slope(x, y, level: float = 0.95) -> CI:
    """Least-squares slope of y on x with its t interval (n - 2 degrees of freedom)."""
    x = np.asarray(list(x), dtype=float)
    y = np.asarray(list(y), dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    n = x.size
    if n < 3 or np.ptp(x) == 0:
        return CI(math.nan, math.nan, math.nan, n)
    xm, ym = x.mean(), y.mean()
    sxx = float(((x - xm) ** 2).sum())
    b = float(((x - xm) * (y - ym)).sum() / sxx)
    resid = y - ym - b * (x - xm)
    se = math.sqrt(float((resid ** 2).sum()) / (n - 2) / sxx)
    h = t_ppf(0.5 + level / 2.0, n - 2) * se
    return CI(b, b - h, b + h, n)
