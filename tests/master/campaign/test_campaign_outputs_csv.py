"""summary.csv and photos.csv written without pandas (uavstudy.outputs.write_summary_csv / write_photos_csv) are
the bytes pandas writes (summary_frame / photos_frame + to_csv(index=False)), compared on thousands of random
tables of the kinds of values the monitor makes: ints, floats of every magnitude (and -0.0, NaN), bools,
strings that need quoting, missing values, and their mixtures.  Where the twin declines it writes nothing."""
import math
import random
import warnings
from types import SimpleNamespace

import pytest

from awkward_values import awkward_float

from uavstudy import outputs as O

COLUMNS = O.SUMMARY_COLUMNS + O.TOTAL_COLUMNS
STRINGS = ["success", "uav_collision", "x, y", 'say "hi"', "two\nlines", "", "é"]


def _value(rng, kind):
    if rng.random() < 0.15:
        return None
    if kind == "int":
        return rng.choice([rng.randint(-10 ** 6, 10 ** 6), 0])
    if kind == "count":         # what a count column holds: ints, or the same as floats
        return rng.choice([rng.randint(0, 40), float(rng.randint(0, 40))])
    if kind == "float":
        return awkward_float(rng)
    if kind == "intfloat":
        return rng.choice([rng.randint(-100, 100), awkward_float(rng)])
    if kind == "bool":
        return rng.random() < 0.5
    if kind == "str":
        return rng.choice(STRINGS)
    return rng.choice([None, 3, -1.5, True, "a,b", math.nan, 2 ** 70, 2 ** 60, -(2 ** 62), 0.5])     # mixed


def _pandas_bytes(tmp_path, make):
    path = tmp_path / "pandas.csv"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            make().to_csv(path, index=False)
    except (TypeError, ValueError, OverflowError):
        return None          # pandas refuses: the twin must decline as well
    return path.read_bytes()


def test_summary_csv_is_what_pandas_writes(tmp_path):
    rng = random.Random(20261127)
    written = 0
    for _ in range(800):
        wild = rng.random() < 0.3          # then any column may hold anything
        kinds = {c: rng.choice(["int", "float", "intfloat", "bool", "str", "mixed"]) if wild else
                 "count" if c in O.COUNT_COLUMNS else rng.choice(["int", "float", "intfloat", "bool", "str"])
                 for c in COLUMNS}
        uavs = [{c: _value(rng, kinds[c]) for c in O.SUMMARY_COLUMNS} for _ in range(rng.randint(0, 4))]
        total = {c: _value(rng, kinds[c]) for c in COLUMNS}
        expected = _pandas_bytes(tmp_path, lambda: O.summary_frame(uavs, total))
        ours = tmp_path / "twin.csv"
        if ours.exists():
            ours.unlink()
        if O.write_summary_csv(uavs, total, ours):
            written += 1
            assert ours.read_bytes() == expected, (kinds, uavs, total)
        else:
            assert not ours.exists()
    # the twin is not a pandas fallback in disguise: most tables (all the monitor makes) are its own
    assert written > 400


@pytest.mark.parametrize("values", [
    [1, 2, None], [1.0, 2, None], [True, None], [True, False], [None, None], [1, 2.5], [2 ** 53 + 1, 0.5],
    ["a", 1, 2.5, True, None], [math.nan, "x"], [-0.0, 0.0], [1e16, 1e-5, 123.0], [2 ** 63], [-(2 ** 63)],
])
@pytest.mark.parametrize("as_int64", [False, True])
def test_one_column_of_every_kind(tmp_path, values, as_int64):
    import pandas as pd
    rows = [{"c": v} for v in values]

    def frame():
        f = pd.DataFrame(rows, columns=["c"])
        if as_int64:
            f["c"] = f["c"].astype("Int64")
        return f
    expected = _pandas_bytes(tmp_path, frame)
    cells = O._column_cells(values, as_int64=as_int64)
    if cells is None:
        return
    O._write_csv(tmp_path / "twin.csv", ["c"], [cells])
    assert (tmp_path / "twin.csv").read_bytes() == expected


def _monitor(rng, n_uavs):
    uavs = [SimpleNamespace(name=f"uav{i + 1}") for i in range(n_uavs)]
    times = [round(rng.uniform(0, 500), rng.choice([0, 1, 3])) for _ in range(6)]     # repeated times: ties
    records = []
    for _ in uavs:
        photos = []
        for _ in range(rng.randint(0, 8)):
            p = {"target": rng.randint(-1, 40), "time": float(rng.choice(times)),
                 "x": rng.choice([rng.uniform(-800, 800), rng.randint(-5, 5)]), "y": rng.uniform(-800, 800)}
            if rng.random() < 0.7:
                p["z"] = rng.choice([rng.uniform(0, 40), math.nan, 30])
            photos.append(p)
        records.append(SimpleNamespace(photos=photos))
    cfg = SimpleNamespace(uavs=uavs, origin=(rng.uniform(-60, 60), rng.uniform(-170, 170), rng.uniform(0, 500)))
    return SimpleNamespace(cfg=cfg, records=records, ctx=object())


def test_photos_csv_is_what_pandas_writes(tmp_path):
    rng = random.Random(7)
    for _ in range(200):
        mon = _monitor(rng, rng.randint(1, 5))
        expected = _pandas_bytes(tmp_path, lambda: O.photos_frame(mon, None))
        assert O.write_photos_csv(mon, tmp_path / "twin.csv")
        assert (tmp_path / "twin.csv").read_bytes() == expected


def test_a_nan_photo_time_is_left_to_pandas(tmp_path):
    rng = random.Random(3)
    mon = _monitor(rng, 2)
    mon.records[0].photos.append({"target": 1, "time": math.nan, "x": 0.0, "y": 0.0})
    assert not O.write_photos_csv(mon, tmp_path / "twin.csv")
    assert not (tmp_path / "twin.csv").exists()
