"""The layout-level statistics (master.campaign.stats: layout_t, layout_difference, layout_ratio, t_power)
against scipy and against brute-force inversion of the t-test."""
import math

import numpy as np
import pytest

from master.campaign import stats as st

scipy_stats = pytest.importorskip("scipy.stats")


def test_layout_t_is_scipys_one_sample_t_interval_and_test():
    rng = np.random.default_rng(3)
    for n in (2, 3, 7, 24):
        v = rng.normal(0.4, 1.0, n)
        c = st.layout_t({f"L{i}": x for i, x in enumerate(v)})
        lo, hi = scipy_stats.t.interval(0.95, n - 1, loc=v.mean(), scale=scipy_stats.sem(v))
        assert (c.estimate, c.low, c.high) == (pytest.approx(v.mean()), pytest.approx(lo), pytest.approx(hi))
        assert c.p == pytest.approx(scipy_stats.ttest_1samp(v, 0.0).pvalue, rel=1e-7)
        assert c.n == n and c.significant == (c.p < 0.05)
    # a level: no test; a total per three layouts: the same interval scaled
    c = st.layout_t([1.0, 2.0, 3.0], null=None, scale=3.0)
    assert math.isnan(c.p) and not c.significant and c.estimate == 6.0
    assert c.high - c.estimate == pytest.approx(3 * 4.302652729749464 / math.sqrt(3))
    # one layout: an estimate, no interval; identical layouts: a zero-width interval, p 0 (or 1 on the null)
    one = st.layout_t([5.0])
    assert one.estimate == 5.0 and math.isnan(one.low) and math.isnan(one.p) and not one.significant
    assert st.layout_t([2.0, 2.0, 2.0]).p == 0.0 and st.layout_t([0.0, 0.0]).p == 1.0


def test_p_below_005_exactly_when_the_interval_excludes_the_null():
    rng = np.random.default_rng(11)
    for _ in range(400):
        n = int(rng.integers(3, 30))
        c = st.layout_t(rng.normal(rng.normal(0, 0.6), 1.0, n))
        assert (c.p < 0.05) == (not (c.low <= 0.0 <= c.high))


def test_layout_difference_pairs_by_layout():
    a = st.layout_t({"x": 1.0, "y": 5.0, "z": 2.0})
    b = st.layout_t({"y": 6.5, "x": 2.0, "z": 3.5, "w": 100.0})     # "w": not in a, left out
    d = st.layout_difference(a, b)
    assert d.n == 3 and d.per_layout == {"y": 1.5, "x": 1.0, "z": 1.5}
    assert d.estimate == pytest.approx(4 / 3)


def test_fieller_interval_is_the_set_of_ratios_the_t_test_does_not_reject():
    rng = np.random.default_rng(5)
    num = {i: float(x) for i, x in enumerate(rng.poisson(30, 12))}
    den = {i: float(x) for i, x in enumerate(rng.poisson(12, 12))}
    c = st.layout_ratio(num, den, null=3.0)
    x, y = np.array(list(num.values())), np.array(list(den.values()))
    assert c.estimate == pytest.approx(x.sum() / y.sum())
    grid = np.linspace(0.5, 6.0, 5501)
    d = x[None, :] - grid[:, None] * y[None, :]              # one row of per-layout differences per ratio
    t = d.mean(axis=1) / (d.std(axis=1, ddof=1) / math.sqrt(x.size))
    kept = grid[2 * scipy_stats.t.sf(np.abs(t), x.size - 1) >= 0.05]
    assert c.low == pytest.approx(min(kept), abs=2e-3) and c.high == pytest.approx(max(kept), abs=2e-3)
    assert c.p == pytest.approx(scipy_stats.ttest_1samp(x - 3.0 * y, 0.0).pvalue, rel=1e-7)
    assert (c.p < 0.05) == (not (c.low <= 3.0 <= c.high))
    # a denominator not significantly above 0: unbounded (no interval), never a false one
    assert math.isnan(st.layout_ratio({0: 5.0, 1: 6.0, 2: 4.0}, {0: 0.0, 1: 3.0, 2: 0.0}).low)


def test_power_of_the_t_test_over_layouts_matches_the_noncentral_t():
    for d_z, n in ((0.6, 24), (0.76, 16), (1.0, 5), (0.6, 2), (0.3, 60)):
        c = scipy_stats.t.ppf(0.975, n - 1)
        nc = d_z * math.sqrt(n)
        ref = 1 - scipy_stats.nct.cdf(c, n - 1, nc) + scipy_stats.nct.cdf(-c, n - 1, nc)
        assert st.t_power(d_z, n) == pytest.approx(ref, abs=1e-4)
    assert st.layouts_for_power(0.6) == 24 and st.layouts_for_power(1.5) < 8


def test_numbers_are_written_without_floating_point_noise():
    assert st.fmt_number(-5.68e-14, 1) == "0.0" and st.fmt_number(-0.004, 2) == "0.00"
    assert st.fmt_number(0.52, 2, signed=True) == "+0.52" and st.fmt_number(-1.25, 1) == "-1.2"
