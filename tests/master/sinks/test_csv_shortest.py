"""The C formatter's doubles are repr's, byte for byte, in every group where a shortest-digits method can go
wrong (``csv_native.hard_doubles``: random bits, every binary exponent at its ends, the smallest subnormals,
exact ties, short decimals, a simulation's values), about 0.4 million here on fresh seeds from a fixed list;
bench/recording/check_shortest.py runs the same groups by the many millions. repr is the independent reference
(CPython's own dtoa, David Gay's correctly rounded shortest digits)."""
import numpy as np
import pyarrow as pa
import pytest

from master.sinks.csv_native import K_MAX, K_MIN, hard_doubles, library, power_of_ten_table, rows_in_chunks


@pytest.fixture(scope="module")
def lib():
    found, why = library()
    if found is None:
        pytest.skip(f"the C formatter is not available: {why}")
    return found


def _text(lib, values) -> list[str]:
    table = pa.table({"x": pa.array(values, pa.float64())})
    return b"".join(bytes(c) for c in rows_in_chunks(lib, table)).decode().split("\n")[:-1]


@pytest.mark.parametrize("seed", [20261129, 7])
def test_every_group_of_hard_doubles_is_written_as_repr(lib, seed):
    groups = hard_doubles(np.random.default_rng(seed), 40_000, part=seed % 5)
    assert len(groups) == 6
    for name, values in groups.items():
        want = [repr(x) for x in values.tolist()]
        got = _text(lib, values)
        assert len(got) == len(want), name
        bad = [(w, g) for w, g in zip(want, got) if w != g]
        assert not bad, f"{name}: {len(bad)} differ, e.g. {bad[:5]}"


def test_every_scale_is_used_and_its_power_of_ten_is_exact():
    # the exponents k that doubles need (floor(q log10 2), and for a power of two floor(q log10 2 - log10 4/3),
    # for q = -1074 .. 971, by exact integer comparison) are the table's range, no more
    def k(q, three_quarters):
        num, den = (1 << max(q, 0)) * (3 if three_quarters else 1), (1 << max(-q, 0)) * (4 if three_quarters else 1)
        k = 0
        while 10 ** max(k, 0) * den > num * 10 ** max(-k, 0):
            k -= 1
        while 10 ** max(k + 1, 0) * den <= num * 10 ** max(-(k + 1), 0):
            k += 1
        return k
    qs = range(-1074, 972)
    ks = {k(q, False) for q in qs} | {k(q, True) for q in qs[1:]}
    assert (min(ks), max(ks)) == (K_MIN, K_MAX)
    table = power_of_ten_table()
    for i, kk in enumerate(range(K_MIN, K_MAX + 1)):
        g = int(table[i, 0]) | int(table[i, 1]) << 64
        assert 1 << 125 < g <= 1 << 126
        # g - 1 <= 10^-k * 2^r < g for the power of two 2^r that puts it in [2^125, 2^126)
        r = 125 - ((10 ** -kk).bit_length() - 1 if kk <= 0 else -(10 ** kk).bit_length())
        lo, hi = (g - 1) * 10 ** max(kk, 0) << max(-r, 0), g * 10 ** max(kk, 0) << max(-r, 0)
        exact = 10 ** max(-kk, 0) << max(r, 0)
        assert lo <= exact < hi, kk
