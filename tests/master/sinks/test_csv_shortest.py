"""The C formatter's doubles are repr's, byte for byte, in every group where a shortest-digits method can go
wrong (``csv_native.hard_doubles``: random bits, every binary exponent at its ends, the smallest subnormals,
exact ties, short decimals, a simulation's values), about 0.4 million here on fresh seeds from a fixed list;
bench/recording/check_shortest.py runs the same groups by the many millions. repr is the independent reference
(CPython's own dtoa, David Gay's correctly rounded shortest digits)."""
import numpy as np
import pyarrow as pa
import pytest

from master.sinks.csv_native import hard_doubles, library, rows_in_chunks


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
