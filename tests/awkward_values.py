"""Values that CSV writers render in their own ways (signed zero, NaN, 0.1 + 0.2, exponents from 1e-30 to 1e30,
2**53): the pandas-free CSV twins are compared with pandas on them."""
from __future__ import annotations

import math


def awkward_float(rng) -> float:
    return rng.choice([rng.uniform(-1e4, 1e4), rng.random() * 10.0 ** rng.randint(-30, 30), float(rng.randint(-9, 9)),
                       -0.0, 0.1 + 0.2, 1e16, 1e-5, 2.0 ** 53, 123456789.125, math.nan])
