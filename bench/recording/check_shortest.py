"""The C CSV formatter's doubles against Python's repr, many millions of them: ``hard_doubles`` (csv_native.py)
in each of its groups (random bits, every binary exponent at its ends, the smallest subnormals, exact ties, short
decimals, values a simulation writes), ``--millions`` per group, fresh seeds each run unless ``--seed``. Prints a
table: values checked and mismatches per group; exits 1 on any mismatch. The suite checks a few million
(tests/master/sinks/test_csv_shortest.py); this is the long run.

    python bench/recording/check_shortest.py [--millions 5] [--seed N]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def formatted(lib, values):
    """The formatter's text of ``values`` (a one-column table), one string per value."""
    import pyarrow as pa

    from master.sinks.csv_native import rows_in_chunks
    table = pa.table({"x": pa.array(values, pa.float64())})
    return b"".join(bytes(c) for c in rows_in_chunks(lib, table)).decode().split("\n")[:-1]


def main(argv=None) -> int:
    import numpy as np

    from master.sinks.csv_native import hard_doubles, library
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--millions", type=float, default=5.0, help="values per group, in millions (default 5)")
    ap.add_argument("--seed", type=int, default=None)
    a = ap.parse_args(argv)
    lib, why = library()
    if lib is None:
        raise SystemExit(f"the C formatter is not available: {why}")
    seed = a.seed if a.seed is not None else int.from_bytes(os.urandom(4), "little")
    total = {}
    bad_examples = []
    per_call = 1_000_000
    left = int(a.millions * 1e6)
    t0 = time.perf_counter()
    part = 0
    while left > 0:
        n = min(per_call, left)
        groups = hard_doubles(np.random.default_rng([seed, part]), n, part)
        for name, values in groups.items():
            got = formatted(lib, values)
            want = [repr(x) for x in values.tolist()]
            bad = [(w, g) for w, g in zip(want, got) if w != g] if got != want else []
            if len(got) != len(want):
                bad.append(("(count)", f"{len(got)} against {len(want)}"))
            checked, wrong = total.get(name, (0, 0))
            total[name] = (checked + len(values), wrong + len(bad))
            bad_examples += bad[:3]
        left -= n
        part += 1
    print(f"the C formatter's doubles against repr: seed {seed}, {time.perf_counter() - t0:.0f} s\n")
    print("| group | values | differ |")
    print("|---|---:|---:|")
    for name, (checked, wrong) in total.items():
        print(f"| {name} | {checked:,} | {wrong} |")
    print(f"| all | {sum(c for c, _ in total.values()):,} | {sum(w for _, w in total.values())} |")
    for want, got in bad_examples[:20]:
        print(f"- repr {want}, formatter {got}")
    return 1 if bad_examples else 0


if __name__ == "__main__":
    raise SystemExit(main())
