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
           "LayoutCI", "layout_t", "layout_difference", "layout_ratio", "t_power", "layouts_for_power", "fmt_number",
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


# ----------------------------------------------------------------------------------- the layout as the unit
@dataclass
class LayoutCI:
    """A statistic over independent replicates (the layouts of a campaign): the mean of one value per layout
    with its two-sided t interval (df = layouts - 1) and, when ``null`` is given, the matching two-sided
    one-sample t-test of mean = null.  Interval and p-value come from the same t distribution, so p < 1 - level
    exactly when the interval excludes the null: they cannot disagree.  ``per_layout``: layout -> value (what
    the interval rests on; matched by layout to compare two statistics, :func:`layout_difference`)."""
    estimate: float
    low: float
    high: float
    p: float
    n: int
    per_layout: dict
    null: float | None = 0.0
    level: float = 0.95

    @property
    def significant(self) -> bool:
        """The interval excludes the null (the same as p < 1 - level)."""
        return (self.null is not None and math.isfinite(self.low)
                and not (self.low <= self.null <= self.high))

    def fmt(self, digits: int = 2, unit: str = "", signed: bool = False) -> str:
        if self.n == 0 or not math.isfinite(self.estimate):
            return "n/a"
        s = fmt_number(self.estimate, digits, signed) + unit
        if math.isfinite(self.low):
            s += f" [{fmt_number(self.low, digits)}, {fmt_number(self.high, digits)}]"
        return s


def fmt_number(x: float, digits: int = 2, signed: bool = False) -> str:
    """``x`` with ``digits`` decimals, without floating-point noise: a value that rounds to zero is written 0
    (never -0.00 or -5.68e-14)."""
    if not math.isfinite(x):
        return "n/a"
    if round(x, digits) == 0:
        x = 0.0
    return f"{x:+.{digits}f}" if signed and x != 0 else f"{x:.{digits}f}"


def t_sf2(t: float, df: float) -> float:
    """Two-sided tail probability P(|T| >= |t|) of Student's t."""
    if not math.isfinite(t):
        return 0.0 if math.isinf(t) else math.nan
    return min(1.0, 2.0 * t_cdf(-abs(t), df))


def layout_t(per_layout, null: float | None = 0.0, level: float = 0.95, scale: float = 1.0,
             floor: float | None = None, ceiling: float | None = None) -> LayoutCI:
    """One value per layout (mapping layout -> value, or a pandas Series indexed by layout) -> their mean with
    the t interval over layouts and the t-test against ``null`` (None: a level, no test).  ``scale``
    multiplies estimate and interval (e.g. a per-layout total expressed per three layouts, the paper's
    repetitions); ``floor``/``ceiling`` cut the interval to what the quantity can take (after scaling)."""
    items = dict(per_layout.items()) if hasattr(per_layout, "items") else dict(enumerate(per_layout))
    # per_layout keeps each layout's value in the statistic's own units (scaled), so that two statistics can
    # be compared layout by layout
    vals = {k: float(v) * scale for k, v in items.items() if v is not None and math.isfinite(float(v))}
    a = np.array(list(vals.values()), dtype=float)
    n = a.size
    if n == 0:
        return LayoutCI(math.nan, math.nan, math.nan, math.nan, 0, vals, null, level)
    m = float(a.mean())
    if n == 1:
        return LayoutCI(m, math.nan, math.nan, math.nan, 1, vals, null, level)
    se = float(a.std(ddof=1)) / math.sqrt(n)
    h = t_ppf(0.5 + level / 2.0, n - 1) * se
    if null is None:
        p = math.nan
    elif se == 0.0:
        p = 1.0 if m == null else 0.0
    else:
        p = t_sf2((m - null) / se, n - 1)
    return LayoutCI(m, *_clip(m - h, m + h, floor, ceiling), p, n, vals, null, level)


def layout_difference(a: LayoutCI, b: LayoutCI, null: float = 0.0, level: float = 0.95) -> LayoutCI:
    """``b - a`` layout by layout (the layouts both have) with its t interval and t-test: how much a change
    (another configuration on the same layouts) moves a statistic."""
    keys = [k for k in b.per_layout if k in a.per_layout]
    return layout_t({k: b.per_layout[k] - a.per_layout[k] for k in keys}, null, level)


def layout_ratio(num, den, null: float | None = 1.0, level: float = 0.95) -> LayoutCI:
    """Ratio of two totals over layouts, sum(num) / sum(den), with Fieller's interval: the values R0 that the
    t-test of mean(num - R0 den) = 0 over layouts does not reject, so the interval and the p-value of the test
    against ``null`` (that same t-test at R0 = null) cannot disagree.  The interval is unbounded (nan) when
    the denominator's own mean is not significantly above zero.  ``per_layout`` holds each layout's ratio
    (nan where its denominator is 0), for reading only."""
    keys = [k for k in num if k in den and math.isfinite(float(num[k])) and math.isfinite(float(den[k]))]
    x = np.array([float(num[k]) for k in keys])
    y = np.array([float(den[k]) for k in keys])
    per = {k: (xi / yi if yi else math.nan) for k, xi, yi in zip(keys, x, y)}
    n = x.size
    if n == 0 or y.sum() == 0:
        return LayoutCI(math.nan, math.nan, math.nan, math.nan, n, per, null, level)
    r = float(x.sum() / y.sum())
    if n == 1:
        return LayoutCI(r, math.nan, math.nan, math.nan, 1, per, null, level)
    t2 = t_ppf(0.5 + level / 2.0, n - 1) ** 2
    xm, ym = x.mean(), y.mean()
    sxx, syy = x.var(ddof=1) / n, y.var(ddof=1) / n
    sxy = float(np.cov(x, y, ddof=1)[0, 1]) / n
    # (xm - R ym)^2 <= t^2 (sxx - 2 R sxy + R^2 syy): a R^2 + b R + c <= 0
    qa, qb, qc = ym * ym - t2 * syy, -2.0 * (xm * ym - t2 * sxy), xm * xm - t2 * sxx
    disc = qb * qb - 4 * qa * qc
    if qa <= 0 or disc < 0:
        low = high = math.nan
    else:
        root = math.sqrt(disc)
        low, high = (-qb - root) / (2 * qa), (-qb + root) / (2 * qa)
    p = math.nan
    if null is not None:
        d = x - null * y
        sd = float(d.std(ddof=1))
        p = (1.0 if d.mean() == 0 else 0.0) if sd == 0 else t_sf2(float(d.mean()) / (sd / math.sqrt(n)), n - 1)
    return LayoutCI(r, low, high, p, n, per, null, level)


_erfc = np.vectorize(math.erfc, otypes=[float])


def t_power(d_z: float, n: int, alpha: float = 0.05) -> float:
    """Power of the two-sided one-sample t-test over ``n`` replicates for a standardised effect ``d_z``
    (mean / sd of the per-layout values): P(|T'| > t_crit) with T' non-central t (df n - 1, non-centrality
    d_z sqrt(n)), integrated over the chi-square distribution of the variance estimate."""
    if n < 2:
        return math.nan
    df = n - 1
    c = t_ppf(1.0 - alpha / 2.0, df)
    delta = abs(d_z) * math.sqrt(n)
    # S = sqrt(V), V ~ chi2(df) (the chi density has no singularity at 0, even for df = 1):
    # T' = (Z + delta) / (S / sqrt(df)); power = E_S[P(|Z + delta| > c S / sqrt(df))]
    s = np.linspace(0.0, math.sqrt(df) + 12.0, 4001)
    w = np.exp((df - 1.0) * np.log(np.maximum(s, 1e-300)) - s * s / 2.0) if df > 1 else np.exp(-s * s / 2.0)
    k = c * s / math.sqrt(df)
    inner = 0.5 * (_erfc((k - delta) / math.sqrt(2.0)) + _erfc((k + delta) / math.sqrt(2.0)))
    return float(np.trapezoid(w * inner, s) / np.trapezoid(w, s))


def layouts_for_power(d_z: float, power: float = 0.8, alpha: float = 0.05, most: int = 200) -> int | None:
    """The fewest layouts with which the two-sided t-test over layouts detects a standardised effect ``d_z``
    with the given power (None beyond ``most``)."""
    for n in range(2, most + 1):
        if t_power(d_z, n, alpha) >= power:
            return n
    return None
